//! Logging for the service: tracing with a human-readable or JSON format,
//! filtered by `RUST_LOG` (default `info`), and a panic hook that reports
//! panics through tracing so they carry the current request or job span
//! (and so its request id or job id) like every other line. Text logs carry
//! colours only when stderr is a terminal.

use std::io::IsTerminal;

use tracing_subscriber::EnvFilter;

/// Installs the global subscriber and the panic hook. Call once, early.
pub fn init(json: bool) {
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info"));
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        // Colours only on a terminal: a file or a collector gets plain text.
        .with_ansi(std::io::stderr().is_terminal());
    let installed = if json {
        builder
            .json()
            .with_current_span(true)
            .with_span_list(true)
            .try_init()
    } else {
        builder.try_init()
    };
    if installed.is_ok() {
        install_panic_hook();
    }
}

/// Replaces the default panic message with a tracing event.
pub fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let payload = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "non-string panic payload".into());
        let location = info
            .location()
            .map(|l| format!("{}:{}:{}", l.file(), l.line(), l.column()))
            .unwrap_or_default();
        let thread = std::thread::current()
            .name()
            .unwrap_or("unnamed")
            .to_string();
        tracing::error!(panic.payload = %payload, panic.location = %location, thread = %thread, "panic");
    }));
}
