//! The `haiko` binary: parses the command line and dispatches; no logic here.

use clap::Parser;

fn main() {
    let cli = haiko::cli::Cli::parse();
    haiko::error::install_panic_recorder();
    if let Err(err) = haiko::cli::catch_panics(|| haiko::cli::run(cli)) {
        eprintln!("haiko: {err}");
        std::process::exit(err.exit_code());
    }
}
