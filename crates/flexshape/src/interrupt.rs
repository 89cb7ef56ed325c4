//! Ctrl-C handling: the first Ctrl-C (or SIGTERM, or SIGHUP) asks the running command to stop
//! after the current frame (so everything written stays whole); a second one exits at once.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set when the user pressed Ctrl-C.
#[derive(Clone)]
pub struct Interrupt(Arc<AtomicBool>);

impl Interrupt {
    /// Installs the handler. If one cannot be installed the command still runs, just without
    /// a graceful stop.
    pub fn install() -> Self {
        let flag = Arc::new(AtomicBool::new(false));
        let f = flag.clone();
        let result = ctrlc::set_handler(move || {
            if f.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
            eprintln!("\ninterrupted: finishing the current frame (Ctrl-C again to quit now)");
        });
        if let Err(e) = result {
            tracing::warn!("cannot install a Ctrl-C handler: {e}");
        }
        Interrupt(flag)
    }

    /// The flag itself, for loops that poll it.
    pub fn flag(&self) -> &AtomicBool {
        &self.0
    }

    /// True once Ctrl-C was pressed.
    pub fn requested(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }
}
