//! Developer tool: the report's speed-against-error study alone, at sizes
//! given on the command line, printing the equal-time table and every
//! render. `cargo run --release --example error_study -- W H REF_SPP SPP...`
//! (defaults: the full report's sizes).

use hybrid::report::budget::Budget;
use hybrid::report::error;

fn main() {
    let args: Vec<u32> = std::env::args()
        .skip(1)
        .map(|a| {
            a.parse().unwrap_or_else(|_| {
                eprintln!("error_study: '{a}' is not a count");
                std::process::exit(2)
            })
        })
        .collect();
    let mut budget = Budget::new(false);
    if args.len() >= 4 {
        budget.error_resolution = (args[0], args[1]);
        budget.reference_spp = args[2];
        budget.error_spp = args[3..].to_vec();
    }
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    match error::measure(&budget, threads) {
        Ok(study) => {
            print!("{}", error::headline(&study));
            println!("{}", error::equal_time_table(&study).markdown());
            println!("{}", error::points_table(&study).markdown());
        }
        Err(e) => {
            eprintln!("error_study: {e}");
            std::process::exit(1)
        }
    }
}
