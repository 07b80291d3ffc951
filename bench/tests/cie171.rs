//! The CIE 171:2006 analytical cases (fixtures/scenes/cie171, expected values from
//! the closed forms in make_cie171.py) at `lumiwall render`'s default target of 1 %.
//! `lumiwall bench cie171` prints the same table.

use std::path::PathBuf;

use lumiwall_bench::cie171::{self, CaseRow, OUR_LIMIT, Quantity};

/// The cases `select` accepts, each printed as it is done.
fn rows(select: impl Fn(&str) -> bool) -> Vec<CaseRow> {
    let cases =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/scenes/cie171/cases.toml");
    cie171::run_selected(&cases, 0.01, select, |r| {
        println!(
            "{:<12} max {:.4} % mean {:.4} % total {:?} estimate {:.3} % {:.2} s",
            r.id,
            100.0 * r.max_rel_error,
            100.0 * r.mean_rel_error,
            r.total_rel_error.map(|t| 100.0 * t),
            100.0 * r.estimated_error,
            r.time_s
        )
    })
    .unwrap()
}

/// The stiffest inter-reflection case (ρ = 0.95: two thirds of the run time), run as
/// its own test so that it shares the machine's cores with the others.
fn stiff(id: &str) -> bool {
    id.contains("ρ=0.95")
}

#[test]
fn cie_171_cases_meet_their_closed_forms_and_the_estimate_bounds_the_inter_reflection() {
    let rows = rows(|id| !stiff(id));
    assert_eq!(rows.len(), 9);
    check(&rows);
}

#[test]
fn cie_171_stiff_inter_reflection_at_rho_0_95_stays_within_its_estimate_and_1_percent() {
    let rows = rows(stiff);
    assert_eq!(rows.len(), 1);
    check(&rows);
}

fn check(rows: &[CaseRow]) {
    for r in rows {
        match r.quantity {
            // direct light at points is computed exactly; flux is conserved exactly
            Quantity::PointIlluminance { points } => {
                assert!(points >= 28, "{}", r.id);
                assert!(r.max_rel_error < 1e-4, "{}: {}", r.id, r.max_rel_error);
            }
            Quantity::ReceivedFlux => {
                assert!(r.max_rel_error < 1e-5, "{}: {}", r.id, r.max_rel_error)
            }
            // inter-reflection: the solver's estimate bounds the error of the total it
            // is relative to, at every ρ up to 0.95, and the indirect part alone meets
            // 1 % at every ρ (at ρ = 0.05, where it is 5 % of the total, it did not
            // while patches sent from subdivided nodes: 1.5 %, see README)
            Quantity::MeanIndirect => {
                let total = r.total_rel_error.unwrap();
                assert!(total <= r.estimated_error, "{}: {total} > estimate", r.id);
                assert!(r.passes(), "{}: {r:?}", r.id);
                assert!(
                    r.max_rel_error <= OUR_LIMIT,
                    "{}: {}",
                    r.id,
                    r.max_rel_error
                );
            }
        }
    }
}
