//! The `anisobond` command: thin layer over the library; prints, reports errors, exits.

mod cli;

fn main() {
    cli::interrupt::remove_staging_on_signals();
    if let Err(e) = cli::run() {
        let e = e.with_user_paths();
        eprintln!("error: {e}");
        std::process::exit(e.exit_code());
    }
}
