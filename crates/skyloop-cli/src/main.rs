//! The skyloop command-line tool: parses arguments, calls the crates, prints tables or JSON.
//!
//! Every failure prints `error: ...` on stderr and exits with status 2.

mod cmd;
mod input;
mod output;

use clap::Parser;

/// Robust flight-control design: from a flight log to a flyable, verified controller.
#[derive(Parser)]
#[command(name = "skyloop", version, about)]
struct Cli {
    #[command(subcommand)]
    command: cmd::Command,
}

/// The message of the last panic, kept by the hook instead of printed: a library may catch its own
/// panics (a third-party parser), and those must not reach the user's terminal.
static LAST_PANIC: std::sync::Mutex<Option<String>> = std::sync::Mutex::new(None);

/// A reader that closed stdout early (`| head`) ends the program quietly; a full disk
/// (`> /dev/full`) is an error with status 2; other panics are only recorded (see `main`).
fn quiet_panics() {
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("unknown cause");
        if msg.contains("failed printing to stdout") {
            if msg.contains("Broken pipe") || msg.contains("os error 32") {
                std::process::exit(0);
            }
            eprintln!("error: cannot write to stdout: {msg}");
            std::process::exit(2);
        }
        if let Ok(mut last) = LAST_PANIC.lock() {
            *last = Some(msg.to_string());
        }
    }));
}

/// `--dt -0.01` as `--dt=-0.01`: clap reads a value that starts with '-' as a flag, so a negative
/// number after an option that takes a value is joined to it (the option's own range check then
/// names it). Only options that take values and only values that parse as numbers are joined.
fn join_negative_values(args: Vec<std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    use clap::CommandFactory;
    let mut cmd = Cli::command();
    let mut out: Vec<std::ffi::OsString> = Vec::with_capacity(args.len());
    let mut i = 0;
    while i < args.len() {
        let a = args[i].to_string_lossy().into_owned();
        if let Some(sub) = cmd.find_subcommand(&a).cloned() {
            cmd = sub;
        }
        let next_negative = args
            .get(i + 1)
            .map(|n| n.to_string_lossy())
            .is_some_and(|n| n.starts_with('-') && n.parse::<f64>().is_ok());
        let takes_value = a.strip_prefix("--").filter(|n| !n.contains('=')).is_some_and(|name| {
            cmd.get_arguments()
                .any(|arg| arg.get_long() == Some(name) && arg.get_action().takes_values())
        });
        if takes_value && next_negative {
            out.push(format!("{a}={}", args[i + 1].to_string_lossy()).into());
            i += 2;
        } else {
            out.push(args[i].clone());
            i += 1;
        }
    }
    out
}

/// `skyloop --markdown-help` prints the CLI reference (`docs/reference/cli.md`) generated from
/// clap's own definitions, so the reference cannot drift from `--help` (a test compares the two).
/// It is hidden from `--help`: it is for the docs, not for users.
fn markdown_help() -> String {
    let options = clap_markdown::MarkdownOptions::new()
        .title("skyloop command-line reference".to_string())
        .show_footer(false)
        .show_table_of_contents(true);
    clap_markdown::help_markdown_custom::<Cli>(&options)
}

fn main() {
    quiet_panics();
    if std::env::args_os().skip(1).eq(["--markdown-help"]) {
        print!("{}", markdown_help());
        return;
    }
    let cli = match Cli::try_parse_from(join_negative_values(std::env::args_os().collect())) {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            std::process::exit(code);
        }
    };
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || cmd::run(cli.command))) {
        Ok(Ok(())) => {}
        Ok(Err(e)) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
        // A panic is a bug of ours: one line naming it, exit status 2, no backtrace.
        Err(_) => {
            let msg = LAST_PANIC.lock().ok().and_then(|m| m.clone()).unwrap_or_default();
            eprintln!("error: internal error (please report it): {msg}");
            std::process::exit(2);
        }
    }
}
