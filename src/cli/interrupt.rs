//! Ctrl-C and a scheduler's time limit: an interrupted command leaves its outputs as they were.

use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
use signal_hook::iterator::Signals;

/// On SIGINT, SIGTERM or SIGHUP: wait for a commit in progress, remove every staging file and
/// folder of the command ([`anisobond::io::remove_staging`]), say so and exit with 128 + the
/// signal's number, as a shell reports a process killed by it.
pub fn remove_staging_on_signals() {
    let Ok(mut signals) = Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            anisobond::io::remove_staging();
            eprintln!("\ninterrupted by signal {signal}: unfinished outputs removed, existing files left as they were");
            std::process::exit(128 + signal);
        }
    });
}
