//! `flexshape`: the command-line application. Thin over the library crates: each command
//! parses its arguments, calls the libraries and reports.

mod cli;
mod commands;
mod interrupt;

use std::io::Write;

use clap::Parser;

/// mimalloc instead of the system allocator: a followed frame makes and drops a few hundred
/// buffers (masks, samples, normal equations), and tracking ran 3–7 % faster with it (one
/// thread, A/B runs of `flexshape bench`). Libraries leave the choice to the program.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    end_quietly_on_failed_prints();
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = cli::Cli::parse();
    match commands::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // Standard error may be full or closed too: nothing more to do then.
            let _ = writeln!(std::io::stderr(), "error: {}", message(&e));
            std::process::ExitCode::FAILURE
        }
    }
}

/// Exit status of a program whose output pipe closed (128 + SIGPIPE), as shells expect.
const CLOSED_PIPE: i32 = 141;

/// A print that fails — standard output or error on a full disk (`/dev/full`) or a closed
/// pipe (`flexshape demo | head -1`) — ends the program with one line (or, for a closed pipe,
/// silently, as Unix tools do) instead of a panic. Files the commands write are flushed per
/// record, so nothing written before is lost.
fn end_quietly_on_failed_prints() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let text = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        let Some(rest) = text.strip_prefix("failed printing to ") else {
            return default(info);
        };
        if rest.contains("Broken pipe") {
            std::process::exit(CLOSED_PIPE);
        }
        let (stream, reason) = rest.split_once(": ").unwrap_or((rest, ""));
        let stream = if stream == "stdout" {
            "output"
        } else {
            "error"
        };
        let _ = writeln!(
            std::io::stderr(),
            "error: cannot write to the standard {stream}: {reason}"
        );
        std::process::exit(1);
    }));
}

/// The error and its causes on one line, each cause once: library errors often name their
/// cause in their own message already.
fn message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}
