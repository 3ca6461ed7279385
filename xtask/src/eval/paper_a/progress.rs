//! Progress bars (indicatif) on stderr; hidden in tests and when stderr is not a terminal
//! (indicatif's own check), so fixture output never depends on them.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Makes progress bars, or hidden ones.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    visible: bool,
}

impl Progress {
    /// Bars drawn on stderr.
    pub fn stderr() -> Self {
        Progress { visible: true }
    }

    /// Bars that draw nothing.
    pub fn hidden() -> Self {
        Progress { visible: false }
    }

    /// Whether bars (and other progress messages) are shown.
    pub fn is_visible(&self) -> bool {
        self.visible
    }

    /// A bar of `len` steps with a message.
    pub fn bar(&self, len: u64, message: &str) -> ProgressBar {
        if !self.visible {
            return ProgressBar::hidden();
        }
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template("{msg:>40} [{bar:30}] {pos}/{len} {elapsed}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar.set_message(message.to_string());
        bar
    }
}
