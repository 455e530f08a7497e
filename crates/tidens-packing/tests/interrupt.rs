//! Stopping a generation: the `stop` callback of `generate_unless` and
//! `jam_unless` is asked often enough that a stop takes effect at once,
//! sees the protocol's progress, and changes nothing when it never stops.

use std::time::{Duration, Instant};

use tidens_packing::{Packing, PackingError, PackingSpec, Progress, RHO0_MAX, Stage};

/// `Packing::generate_unless` or `Packing::jam_unless`.
type Generate =
    fn(&PackingSpec, &mut dyn FnMut(&Progress) -> bool) -> Result<Packing, PackingError>;

/// What a stopped generation saw: the longest wait between two calls of
/// `stop` (from the start to the first call included), the time from the
/// stop to the return, and the calls' progress.
struct Watched {
    result: Result<Packing, PackingError>,
    longest_gap: Duration,
    after_stop: Duration,
    seen: Vec<Progress>,
}

/// Runs `make` with a `stop` that answers true once `stop_after` has passed.
fn watched(make: Generate, spec: &PackingSpec, stop_after: Duration) -> Watched {
    let start = Instant::now();
    let mut last_call = start;
    let mut longest_gap = Duration::ZERO;
    let mut stopped_at = None;
    let mut seen = Vec::new();
    let result = make(spec, &mut |p| {
        let now = Instant::now();
        longest_gap = longest_gap.max(now - last_call);
        last_call = now;
        seen.push(*p);
        if now - start >= stop_after {
            stopped_at.get_or_insert(now);
            true
        } else {
            false
        }
    });
    let after_stop = stopped_at.map_or(Duration::MAX, |t| t.elapsed());
    Watched {
        result,
        longest_gap,
        after_stop,
        seen,
    }
}

/// 10000 spheres jammed take minutes; a stop asked for after 0.3 s ends
/// the generation with `Interrupted` at once, and `stop` was never kept
/// waiting 0.2 s (the neighbour lists of 10000 particles included).
#[test]
fn a_stop_ends_a_large_jam_promptly() {
    let spec = PackingSpec {
        particles: 10_000,
        rho0: RHO0_MAX,
        ..PackingSpec::default()
    };
    let w = watched(Packing::jam_unless, &spec, Duration::from_millis(300));
    let Err(PackingError::Interrupted {
        stage, rel_density, ..
    }) = w.result
    else {
        panic!("not interrupted: {:?}", w.result.map(|p| p.rel_density()));
    };
    assert!(
        w.after_stop < Duration::from_millis(50),
        "{:?} from the stop to the return",
        w.after_stop
    );
    assert!(
        w.longest_gap < Duration::from_millis(200),
        "stop waited {:?} between two calls",
        w.longest_gap
    );
    let last = w.seen.last().expect("stop was called");
    assert_eq!((stage, rel_density), (last.stage, last.rel_density));
    let message = PackingError::Interrupted {
        stage,
        rel_density,
        densest: last.densest,
    }
    .to_string();
    assert!(message.starts_with("interrupted"), "{message}");
}

/// A stop at the very first call: nothing is relaxed, `Interrupted` at
/// the start, from `generate_unless` as from `jam_unless`.
#[test]
fn a_stop_at_the_first_call_ends_at_the_start() {
    let spec = PackingSpec {
        particles: 2000,
        ..PackingSpec::default()
    };
    for make in [Packing::generate_unless, Packing::jam_unless] {
        let mut calls = 0;
        let result = make(&spec, &mut |_| {
            calls += 1;
            true
        });
        assert_eq!(calls, 1);
        assert_eq!(
            result,
            Err(PackingError::Interrupted {
                stage: Stage::Start,
                rel_density: 0.25,
                densest: 0.0
            })
        );
    }
}

/// A `stop` that never stops changes nothing (the same packing, bit for
/// bit) and sees the protocol go by: the start, the compression, the
/// shakes of a target above jamming, densities that only grow.
#[test]
fn progress_follows_the_protocol_and_a_silent_stop_changes_nothing() {
    let spec = PackingSpec {
        particles: 32,
        rho0: 0.64,
        seed: 3,
        ..PackingSpec::default()
    };
    let mut seen: Vec<Progress> = Vec::new();
    let watched = Packing::generate_unless(&spec, &mut |p| {
        seen.push(*p);
        false
    });
    assert_eq!(watched, Packing::generate(&spec));
    let first = seen.first().expect("stop was called");
    assert_eq!((first.stage, first.rel_density), (Stage::Start, 0.25));
    assert!(seen.iter().any(|p| p.stage == Stage::Compress));
    for w in seen.windows(2) {
        assert_eq!(w[1].iterations, w[0].iterations + 1);
        assert!(w[1].densest >= w[0].densest && w[1].round >= w[0].round);
    }
    // Asking for more than the protocol reaches shakes, round after round
    // (16 spheres in a cube order near 0.69 at most).
    let mut rounds = 0;
    let too_dense = Packing::generate_unless(
        &PackingSpec {
            particles: 16,
            rho0: RHO0_MAX,
            ..spec
        },
        &mut |p| {
            if p.stage == Stage::Shake {
                rounds = rounds.max(p.round);
            }
            false
        },
    );
    assert!(matches!(
        too_dense,
        Err(PackingError::Rho0Unreachable { .. })
    ));
    assert_eq!(rounds, 20);
}
