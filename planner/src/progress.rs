//! Progress of long commands (studies, closed loop, replay of many plans) on stderr.
//!
//! Library loops report through [`begin`], [`advance`] and [`end`]; nothing is shown
//! unless a program installs a [`Sink`] first ([`install`]). With the `progress` feature,
//! [`install_terminal`] installs a bar drawn by `indicatif` on stderr, only when stderr is
//! a terminal: piped output, files and `--json` runs stay free of it. Reporting never
//! fails and never blocks; drawing is rate-limited by the sink.

use std::sync::OnceLock;

/// Where progress goes.
pub trait Sink: Send + Sync {
    /// A task of `total` steps named `title` starts (0: unknown length).
    fn begin(&self, total: u64, title: &str);
    /// One step done; `label` names the next or the finished item.
    fn advance(&self, label: &str);
    /// The task ended; the progress line is cleared.
    fn end(&self);
}

static SINK: OnceLock<Box<dyn Sink>> = OnceLock::new();

/// Installs the process's progress sink; `false` if one is installed already.
pub fn install(sink: Box<dyn Sink>) -> bool {
    SINK.set(sink).is_ok()
}

/// Starts a task of `total` steps (see [`Sink::begin`]).
pub fn begin(total: u64, title: &str) {
    if let Some(s) = SINK.get() {
        s.begin(total, title);
    }
}

/// One step of the current task done (see [`Sink::advance`]).
pub fn advance(label: &str) {
    if let Some(s) = SINK.get() {
        s.advance(label);
    }
}

/// Ends the current task (see [`Sink::end`]).
pub fn end() {
    if let Some(s) = SINK.get() {
        s.end();
    }
}

#[cfg(feature = "progress")]
mod bar {
    use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
    use std::sync::Mutex;
    use std::time::Duration;

    /// An `indicatif` bar on stderr, one task at a time.
    pub(super) struct Bar(pub(super) Mutex<Option<ProgressBar>>);

    impl super::Sink for Bar {
        fn begin(&self, total: u64, title: &str) {
            let bar = if total > 0 {
                ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr())
            } else {
                ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr())
            };
            let template = if total > 0 {
                "{prefix} [{bar:30}] {pos}/{len} {msg} ({elapsed})"
            } else {
                "{prefix} {spinner} {msg} ({elapsed})"
            };
            if let Ok(style) = ProgressStyle::with_template(template) {
                bar.set_style(style.progress_chars("=> "));
            }
            bar.set_prefix(title.to_string());
            if total == 0 {
                bar.enable_steady_tick(Duration::from_millis(200));
            }
            if let Ok(mut slot) = self.0.lock() {
                if let Some(old) = slot.replace(bar) {
                    old.finish_and_clear();
                }
            }
        }

        fn advance(&self, label: &str) {
            if let Ok(slot) = self.0.lock() {
                if let Some(bar) = slot.as_ref() {
                    bar.set_message(label.to_string());
                    bar.inc(1);
                }
            }
        }

        fn end(&self) {
            if let Ok(mut slot) = self.0.lock() {
                if let Some(bar) = slot.take() {
                    bar.finish_and_clear();
                }
            }
        }
    }
}

/// Installs an `indicatif` bar on stderr when stderr is a terminal and `quiet` is false
/// (a `--json` run); returns whether it did.
#[cfg(feature = "progress")]
pub fn install_terminal(quiet: bool) -> bool {
    use std::io::IsTerminal;
    if quiet || !std::io::stderr().is_terminal() {
        return false;
    }
    install(Box::new(bar::Bar(std::sync::Mutex::new(None))))
}
