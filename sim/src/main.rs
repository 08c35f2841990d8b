use clap::Parser;

fn main() {
    let cli = sim::cli::Cli::parse();
    if let Err(e) = sim::run(cli) {
        eprintln!("waamtwin: {e}");
        std::process::exit(e.exit_code());
    }
}
