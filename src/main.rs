//! The `anisobond` command: thin layer over the library; prints, reports errors, exits.

mod cli;

fn main() {
    if let Err(e) = cli::run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
