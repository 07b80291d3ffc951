//! Visibility sampled over poses at key poses (Hahn 2000, 4.3.4–4.3.5): a ray is
//! tested at every k-th pose of a run; where two neighbouring keys agree, the poses
//! between them take their answer, and where they differ the interval is bisected
//! down to single poses. The key spacing is chosen so that nothing moves further
//! between two keys than half an element edge (the spacing of the quadrature points),
//! as Hahn suggests: visibility features smaller than that can be missed, like
//! those between the spatial samples of one frame.

use crate::scene::V3;

/// How far apart the poses are at which visibility is tested.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeySpacing {
    /// From the motion: the most poses over which no moving vertex travels more
    /// than half an element edge, at most [`MAX_KEY_SPACING`].
    Auto,
    /// Every n-th pose (1: every pose, exact).
    Every(usize),
}

/// Largest automatic key spacing.
pub const MAX_KEY_SPACING: usize = 8;

/// The key spacing for poses whose largest vertex step from one pose to the next is
/// `largest_step_m`, on a mesh whose longest element edge is `max_edge_m`.
pub(crate) fn key_spacing(choice: KeySpacing, largest_step_m: f64, max_edge_m: f64) -> usize {
    match choice {
        KeySpacing::Every(n) => n.max(1),
        KeySpacing::Auto => {
            if largest_step_m <= 0.0 {
                return MAX_KEY_SPACING;
            }
            let keys = (0.5 * max_edge_m / largest_step_m).floor();
            if keys.is_finite() {
                (keys as usize).clamp(1, MAX_KEY_SPACING)
            } else {
                1
            }
        }
    }
}

/// The largest distance any vertex of `from` travels to its place in `to`.
pub(crate) fn largest_step_m(from: &[V3], to: &[V3]) -> f64 {
    from.iter()
        .zip(to)
        .map(|(a, b)| (b - a).norm())
        .fold(0.0, f64::max)
}

/// Fills `out[p]` for the poses `first..=last` with `test(p)`, testing at every
/// `spacing`-th pose and bisecting between keys that differ.
pub(crate) fn sample_run(
    first: usize,
    last: usize,
    spacing: usize,
    test: &mut dyn FnMut(usize) -> bool,
    out: &mut [bool],
) {
    let spacing = spacing.max(1);
    let mut a = first;
    let mut va = test(a);
    out[a] = va;
    while a < last {
        let b = a.saturating_add(spacing).min(last);
        let vb = test(b);
        fill(a, b, va, vb, test, out);
        (a, va) = (b, vb);
    }
}

/// Fills `a..=b` given the answers at both ends.
fn fill(
    a: usize,
    b: usize,
    va: bool,
    vb: bool,
    test: &mut dyn FnMut(usize) -> bool,
    out: &mut [bool],
) {
    if va == vb || b - a <= 1 {
        let mid = if va == vb { va } else { vb };
        out[a + 1..b].fill(mid);
        out[a] = va;
        out[b] = vb;
        return;
    }
    let m = (a + b) / 2;
    let vm = test(m);
    fill(a, m, va, vm, test, out);
    fill(m, b, vm, vb, test, out);
}

/// The runs of consecutive numbers in the ascending list `poses`, as (first, last).
pub(crate) fn runs_of(poses: &[usize]) -> Vec<(usize, usize)> {
    let mut runs = Vec::new();
    let mut i = 0;
    while i < poses.len() {
        let mut j = i;
        while j + 1 < poses.len() && poses[j + 1] == poses[j] + 1 {
            j += 1;
        }
        runs.push((poses[i], poses[j]));
        i = j + 1;
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampling_at_keys_finds_every_change_that_lasts_at_least_the_key_spacing() {
        // blocked in poses 13..=20 and 41..=44 of 0..=59
        let truth = |p: usize| (13..=20).contains(&p) || (41..=44).contains(&p);
        for spacing in [1, 2, 4] {
            let mut out = vec![false; 60];
            let mut tests = 0;
            sample_run(
                0,
                59,
                spacing,
                &mut |p| {
                    tests += 1;
                    truth(p)
                },
                &mut out,
            );
            let wrong: Vec<usize> = (0..60).filter(|&p| out[p] != truth(p)).collect();
            assert!(wrong.is_empty(), "spacing {spacing}: wrong at {wrong:?}");
            if spacing == 4 {
                assert!(tests < 40, "{tests} tests at spacing 4");
            }
        }
    }

    #[test]
    fn a_change_shorter_than_the_key_spacing_can_be_missed_and_is_exact_at_spacing_one() {
        let truth = |p: usize| p == 5;
        let mut out = vec![false; 12];
        sample_run(0, 11, 8, &mut |p| truth(p), &mut out);
        assert!(
            !out[5],
            "a one-pose blocker between keys 0 and 8 is not seen"
        );
        sample_run(0, 11, 1, &mut |p| truth(p), &mut out);
        assert!(out[5] && out.iter().filter(|b| **b).count() == 1);
    }

    #[test]
    fn a_spacing_beyond_the_run_tests_its_ends_and_bisects_between_them() {
        let truth = |p: usize| p >= 7;
        let mut out = vec![false; 12];
        sample_run(3, 11, usize::MAX, &mut |p| truth(p), &mut out);
        assert!((3..=11).all(|p| out[p] == truth(p)));
    }

    #[test]
    fn runs_of_consecutive_poses_are_split_at_gaps() {
        assert_eq!(runs_of(&[0, 1, 2, 5, 7, 8]), vec![(0, 2), (5, 5), (7, 8)]);
    }

    #[test]
    fn the_automatic_spacing_keeps_the_travel_between_keys_within_half_an_edge() {
        assert_eq!(key_spacing(KeySpacing::Auto, 0.004, 0.05), 6);
        assert_eq!(key_spacing(KeySpacing::Auto, 0.001, 0.05), MAX_KEY_SPACING);
        assert_eq!(key_spacing(KeySpacing::Auto, 0.1, 0.05), 1);
        assert_eq!(key_spacing(KeySpacing::Every(0), 0.1, 0.05), 1);
    }
}
