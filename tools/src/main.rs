//! The `caoen` command line.
#![forbid(unsafe_code)]

use std::io::Write;
use std::process::ExitCode;

use clap::Parser;

/// Prefix of the panic message of `print!` when writing to stdout fails.
const PRINT_FAILED: &str = "failed printing to stdout";

fn panic_message(payload: &(dyn std::any::Any + Send)) -> &str {
    payload
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| payload.downcast_ref::<&str>().copied())
        .unwrap_or("")
}

/// Whether a panic came from `print!` failing on stdout (most output goes through
/// `caoen_cli::output`, which returns errors instead; this covers the rest).
fn is_print_failure(payload: &(dyn std::any::Any + Send)) -> bool {
    panic_message(payload).starts_with(PRINT_FAILED)
}

fn fail(e: &caoen_cli::failure::CliError) -> ExitCode {
    let mut message = e.to_string();
    // The library states the need and the budget; how to raise the budget is this
    // program's to say, since the budget is its option.
    if message.contains(caoen::budget::OVER_BUDGET) {
        message.push_str(" (raise it with --max-memory)");
    }
    // One line, whatever a file put into the message.
    eprintln!("error: {}", caoen::surface::error::printable(&message));
    ExitCode::from(e.exit_code())
}

fn main() -> ExitCode {
    // A failed print is reported as one line by the catch below, not as a panic.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !is_print_failure(info.payload()) {
            default_hook(info);
        }
    }));
    let cli = caoen_cli::cli::Cli::parse();
    let result = match std::panic::catch_unwind(|| caoen_cli::commands::run(cli)) {
        Ok(r) => r,
        Err(payload) if is_print_failure(payload.as_ref()) => {
            let msg = panic_message(payload.as_ref());
            // A reader that went away (`caoen ... | head`) chose to stop reading.
            if msg.contains("Broken pipe") {
                return ExitCode::SUCCESS;
            }
            let reason = msg.strip_prefix(PRINT_FAILED).unwrap_or(msg);
            let reason = reason.trim_start_matches(':').trim();
            eprintln!(
                "error: {}: {}",
                caoen_cli::output::STDOUT,
                reason.lines().next().unwrap_or("")
            );
            return ExitCode::FAILURE;
        }
        Err(payload) => std::panic::resume_unwind(payload),
    };
    // Output still buffered in stdout must reach it, or the command failed.
    let result = result.and_then(|()| {
        std::io::stdout()
            .flush()
            .map_err(|e| caoen_cli::failure::CliError::io(caoen_cli::output::STDOUT, e))
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is_broken_pipe() => ExitCode::SUCCESS,
        Err(e) => fail(&e),
    }
}
