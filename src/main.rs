//! The `haiko` binary: parses the command line and dispatches; no logic here.

use clap::Parser;

fn main() {
    let cli = haiko::cli::Cli::parse();
    haiko::cli::install_panic_hook();
    if let Err(err) = haiko::cli::catch_panics(|| haiko::cli::run(cli)) {
        eprintln!("haiko: {err}");
        std::process::exit(err.exit_code());
    }
}
