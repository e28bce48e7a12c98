//! The H200 report's figures (docs/gpu.md#reports, kernel ms at 3840x2160 unless sized) and the
//! check that the model ranks the workloads as measured and
//! predicts every ratio between two within 1.5x.

use std::path::Path;
use std::process::ExitCode;

use raycast::model::Traversal;

use crate::{Job, device, json_line, model};

/// A workload of the report: scene (under the bench folder), size, listed rays, f64, the
/// traversal the kernel used for it, and the measured ms (the middle of the report's range).
pub struct Measured {
    pub scene: &'static str,
    pub size: [u32; 2],
    pub rays: Option<usize>,
    pub f64: bool,
    pub traversal: Traversal,
    pub ms: f64,
}

const fn camera(
    scene: &'static str,
    size: [u32; 2],
    f64: bool,
    traversal: Traversal,
    ms: f64,
) -> Measured {
    Measured {
        scene,
        size,
        rays: None,
        f64,
        traversal,
        ms,
    }
}

use Traversal::{Packets, PerRay};

/// The H200 report of 2026-11-30 at da72079: each kernel over buffers kept across casts and
/// dispatched back to back (`kernel_ab --traversal`, median of 5 rounds), a cast in one part.
pub const REPORT: &[Measured] = &[
    camera("torus/torus.json", [3840, 2160], false, PerRay, 1.256),
    camera("torus/torus.json", [3840, 2160], true, PerRay, 1.869),
    camera("torus/torus.json", [3840, 2160], false, Packets, 1.743),
    camera("torus5m/torus.json", [3840, 2160], false, PerRay, 1.857),
    camera("torus5m/torus.json", [3840, 2160], false, Packets, 3.261),
    camera("torus5m/torus.json", [960, 540], false, PerRay, 0.376),
    camera("torus5m/torus.json", [960, 540], false, Packets, 2.088),
    camera("spheres/spheres.json", [3840, 2160], false, PerRay, 0.299),
    camera("spheres/spheres.json", [3840, 2160], false, Packets, 0.364),
];

/// Two measured times closer than this are a tie: their order is not checked.
const TIE: f64 = 1.2;
/// The most a predicted ratio between two workloads may differ from the measured one.
const RATIO: f64 = 1.5;

/// What is wrong with `predicted` (ms, one per measured `ms`): pairs out of the measured order
/// or with a ratio beyond 1.5x of the measured ratio.
pub fn misfits(measured: &[f64], predicted: &[f64]) -> Vec<String> {
    let mut wrong = Vec::new();
    for a in 0..measured.len() {
        for b in a + 1..measured.len() {
            let m = measured[a] / measured[b];
            let p = predicted[a] / predicted[b];
            if (m > TIE && p < 1.0) || (m < 1.0 / TIE && p > 1.0) {
                wrong.push(format!(
                    "{a} and {b} out of order: measured {m:.2}, predicted {p:.2}"
                ));
            }
            if (p / m).max(m / p) > RATIO {
                wrong.push(format!("{a} over {b}: measured {m:.2}, predicted {p:.2}"));
            }
        }
    }
    wrong
}

pub fn run(bench: &Path) -> ExitCode {
    let h200 = device::H200;
    let mut predicted = Vec::new();
    for m in REPORT {
        let job = Job {
            scene: bench.join(m.scene).to_string_lossy().into_owned(),
            size: Some(m.size),
            rays: m.rays,
            f64: m.f64,
            instanced: false,
        };
        match model(&job, &h200, m.traversal) {
            Ok(f) => {
                println!("{} measured_ms={}", json_line(&job, &h200, &f), m.ms);
                predicted.push(f.predicted_ms);
            }
            Err(e) => {
                eprintln!("gpu_model: {e}");
                return ExitCode::from(2);
            }
        }
    }
    let measured: Vec<f64> = REPORT.iter().map(|m| m.ms).collect();
    let wrong = misfits(&measured, &predicted);
    for w in &wrong {
        println!("misfit: {w}");
    }
    println!(
        "{} of {} pairs misfit",
        wrong.len(),
        measured.len() * (measured.len() - 1) / 2
    );
    if wrong.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_report_agrees_with_itself_and_a_model_off_by_more_than_1_5x_misfits() {
        let measured: Vec<f64> = REPORT.iter().map(|m| m.ms).collect();
        assert!(misfits(&measured, &measured).is_empty());
        let scaled: Vec<f64> = measured.iter().map(|m| m * 3.0).collect();
        assert!(
            misfits(&measured, &scaled).is_empty(),
            "a constant factor keeps every ratio"
        );
        let mut off = measured.clone();
        off[2] *= 1.6;
        assert!(!misfits(&measured, &off).is_empty());
        let mut swapped = measured.clone();
        swapped.swap(0, 3);
        assert!(
            misfits(&measured, &swapped)
                .iter()
                .any(|w| w.contains("out of order"))
        );
    }
}
