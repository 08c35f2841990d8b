use clap::Parser;

fn main() {
    let cli = sim::cli::Cli::parse();
    if let sim::cli::Command::Follow { .. } = cli.command {
        sim::commands::follow::catch_ctrl_c();
    }
    // The command runs on one of rayon's workers, not beside them: the voxel model's parallel
    // step (tens of thousands a run) is then split onto that worker's own queue, instead of
    // being injected into the pool by an outside thread that sleeps until it is done and is
    // woken again every step (docs/PERFORMANCE.md, "Threads").
    if let Err(e) = rayon::scope(|_| sim::run(cli)) {
        eprintln!("waamtwin: {e}");
        std::process::exit(e.exit_code());
    }
}
