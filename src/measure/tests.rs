use super::*;

#[test]
fn the_median_interval_brackets_the_median_and_narrows_with_more_samples() {
    let few: Vec<f64> = (1..=9).map(f64::from).collect();
    let (lo, m, hi) = median_interval(&few);
    assert!(lo < m && m < hi && m == 5.0, "{lo} {m} {hi}");
    let many: Vec<f64> = (1..=401).map(f64::from).collect();
    let (lo2, m2, hi2) = median_interval(&many);
    assert_eq!(m2, 201.0);
    assert!((hi2 - lo2) / m2 < (hi - lo) / m, "{lo2}..{hi2} of {m2}");
}

#[test]
fn a_paired_ratio_is_taken_round_by_round() {
    // The machine slowed in rounds 2 and 3 for both runs; `a` is 0.9 of
    // `b` in every round.
    let b = [1.0, 1.0, 2.0, 2.0, 1.0];
    let (lo, m, hi) = paired_ratio(&b.map(|x| 0.9 * x), &b);
    assert!(
        [lo, m, hi].iter().all(|r| (r - 0.9).abs() < 1e-12),
        "{lo} {m} {hi}"
    );
    // The same times out of step with `b`'s rounds: the same medians,
    // but rounds whose ratios spread.
    let (lo, m, hi) = paired_ratio(&[0.9, 1.8, 1.8, 0.9, 0.9], &b);
    assert!(hi - lo > 1.0 && m == 0.9, "{lo} {m} {hi}");
}

#[test]
fn the_interleaved_samples_keep_every_round_of_every_run() {
    let mut calls = Vec::new();
    let samples = time_interleaved_samples(3, 4, |i| calls.push(i));
    assert_eq!(samples.len(), 3);
    assert!(samples
        .iter()
        .all(|s| s.len() == 4 && s.iter().all(|&t| t >= 0.0)));
    // One warm-up each, then rounds forwards and backwards: a run's
    // neighbour is the same in every round.
    assert_eq!(calls, [0, 1, 2, 0, 1, 2, 2, 1, 0, 0, 1, 2, 2, 1, 0]);
}

#[test]
fn every_timed_pass_follows_a_primer_of_its_own_run() {
    let settle = Settle {
        min: 1,
        max: 2,
        within: 0.0,
    };
    let mut calls = Vec::new();
    time_settled(2, settle, |i, pass| calls.push((i, pass)));
    use Pass::{Prime as P, Timed as T};
    // One timed warm-up each, then rounds forwards and backwards.
    let expected = [
        (0, T),
        (1, T),
        (0, P),
        (0, T),
        (1, P),
        (1, T),
        (1, P),
        (1, T),
        (0, P),
        (0, T),
    ];
    assert_eq!(calls, expected);
    let rays: Vec<u32> = (0..100).collect();
    assert_eq!(Pass::Prime.part(&rays).len(), 7);
    assert_eq!(Pass::Timed.part(&rays).len(), 100);
    assert_eq!(Pass::Prime.part(&rays[..1]).len(), 1);
}

#[test]
fn runs_of_equal_work_settle_and_a_cap_of_one_round_does_not() {
    let work = |n: u64| (0..n).fold(0u64, |a, i| a.wrapping_mul(31).wrapping_add(i));
    let settle = Settle {
        min: 5,
        max: 40,
        within: 0.5,
    };
    let t = time_settled(2, settle, |_, _| {
        std::hint::black_box(work(200_000));
    });
    assert!(t.settled, "widest {} after {} rounds", t.widest, t.rounds);
    assert!(t.cpu.iter().all(|m| m.median > 0.0) && t.wall.len() == 2);
    let capped = time_settled(
        2,
        Settle {
            min: 1,
            max: 1,
            within: 0.0,
        },
        |i, _| {
            std::hint::black_box(work(1000 * (i as u64 + 1)));
        },
    );
    assert!(!capped.settled && capped.rounds == 1);
}
