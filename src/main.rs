//! The `anisobond` command: thin layer over the library; prints, reports errors, exits.

mod cli;

fn main() {
    cli::interrupt::remove_staging_on_signals();
    if let Err(e) = cli::run() {
        eprintln!("error: {}", e.with_user_paths());
        std::process::exit(1);
    }
}
