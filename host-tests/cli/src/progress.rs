//! Progress bars of the commands (a bar for `campaign`, `discover`, `history`, `fleet`, `compare`
//! and `detectability`; a spinner for `identify`, `commission`, `simulate` and `firmware-trace`,
//! whose work runs in one call), drawn with indicatif on stderr. Every command but `params`
//! (which prints a template at once) takes `-q`/`--quiet` ([`ProgressArgs`]).
//!
//! A bar is shown only when the user can see it: not with `--quiet`, and not when stdout is not
//! a terminal ([`std::io::IsTerminal`]), since a command whose output goes to a file or a pipe is
//! a script's, and its stderr is then a log that progress frames would clutter. indicatif hides
//! a bar on its own when stderr is not a terminal.

use std::io::IsTerminal;
use std::time::Duration;

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

/// `--quiet`, shared by the commands that show a progress bar.
#[derive(Args, Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ProgressArgs {
    /// No progress bar on stderr (there is none either when stdout is not a terminal).
    #[arg(long, short = 'q')]
    pub quiet: bool,
}

impl ProgressArgs {
    /// Whether a bar is drawn: not `--quiet`, and stdout is a terminal.
    pub fn visible(&self) -> bool {
        !self.quiet && std::io::stdout().is_terminal()
    }
}

/// A bar of `len` steps named `unit` (`runs`, `fits`) on stderr, or a hidden one when `visible`
/// is false (its methods then do nothing).
pub fn bar(len: u64, unit: &str, visible: bool) -> ProgressBar {
    if !visible {
        return ProgressBar::hidden();
    }
    let template = format!("{{elapsed_precise}} [{{bar:40}}] {{pos}}/{{len}} {unit} {{msg}} eta {{eta}}");
    let b = ProgressBar::new(len);
    b.set_style(ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()));
    b.enable_steady_tick(Duration::from_millis(500));
    b
}

/// A spinner with the elapsed time and `message` on stderr, for work of unknown length, or a
/// hidden one when `visible` is false.
pub fn spinner(message: String, visible: bool) -> ProgressBar {
    if !visible {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new_spinner();
    b.set_style(
        ProgressStyle::with_template("{spinner} {elapsed_precise} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    b.set_message(message);
    b.enable_steady_tick(Duration::from_millis(200));
    b
}
