//! Progress lines on a terminal: an indicatif spinner on stderr, hidden when stderr is not a
//! terminal (tests, pipes), so what a script reads is unchanged.

use std::io::IsTerminal;
use std::time::Duration;

/// A spinner whose message says what runs; `finish_and_clear` removes it.
pub fn spinner() -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new_spinner();
    bar.enable_steady_tick(Duration::from_millis(100));
    bar
}
