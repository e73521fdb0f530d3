//! Progress bars (indicatif) on stderr, drawn only when stderr is a terminal: piped or logged
//! output gets the one-line messages and no bar.

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A bar of `total` steps labelled `title` (current work in its message); hidden when `enabled`
/// is false or stderr is not a terminal.
pub fn bar(enabled: bool, total: u64, title: &str) -> ProgressBar {
    if !enabled || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(
            "{prefix} [{elapsed_precise}] [{bar:30}] {pos}/{len} ETA {eta} {msg}",
        )
        .expect("a valid template")
        .progress_chars("=> "),
    );
    bar.set_prefix(title.to_string());
    bar
}

/// Prints a line above the bar (or plainly, when there is none).
pub fn note(bar: &ProgressBar, line: &str) {
    if bar.is_hidden() {
        eprintln!("{line}");
    } else {
        bar.println(line);
    }
}
