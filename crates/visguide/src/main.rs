//! The `visguide` command line; `visguide --help` and `visguide help SUBCOMMAND` describe it.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
