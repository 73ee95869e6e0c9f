//! `kincal`: kinematic calibration of industrial robots from the command line.

use clap::Parser;

#[derive(Parser)]
#[command(
    name = "kincal",
    version,
    about = "kincal: kinematic calibration of industrial robots — calibrate real laser-tracker \
             data, and run Monte Carlo studies of a virtual KUKA KR1000",
    after_help = "Quick start (from the repository root):
  kincal identify --robot scenarios/robots/ur10.json \\
      --data data/ur10-ipa/series-b-joint-configurations.csv --every 15 --out ur10-cal
  kincal campaign scenarios/paper-kr1000.json --out my-run

`kincal <command> --help` shows each command's options and an example."
)]
struct Cli {
    #[command(subcommand)]
    cmd: kincal::Command,
}

fn main() {
    kincal::exit_on_error(kincal::run(Cli::parse().cmd));
}
