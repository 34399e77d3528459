//! Monte Carlo: many runs over sampled vehicle parameters, disturbance magnitudes and noise seeds, in
//! parallel (rayon) with a progress bar; summary statistics of the metrics.

use crate::disturbance::DisturbanceSpec;
use crate::error::{Result, SimError};
pub use crate::scenario::MonteCarloSpec;
use crate::scenario::Scenario;
use crate::sim::{log_every, Metrics, Simulation};
use rand::rngs::SmallRng;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;

/// Most runs one call runs (a million runs of a few seconds of flight each is days of CPU; a
/// larger campaign is split into ranges, e.g. Slurm array jobs with `--seeds A..B`).
pub const MAX_RUNS: usize = 1_000_000;

/// Statistics of one metric over the runs.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Stat {
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation.
    pub std: f64,
    /// Minimum.
    pub min: f64,
    /// 95th percentile (nearest rank).
    pub p95: f64,
    /// Maximum.
    pub max: f64,
}

/// Summary of a Monte Carlo study.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Summary {
    /// Runs done.
    pub runs: usize,
    /// Runs that crashed.
    pub crashed: usize,
    /// Runs whose error never settled.
    pub unsettled: usize,
    /// max_abs_error statistics.
    pub max_abs_error: Stat,
    /// rms_error statistics.
    pub rms_error: Stat,
    /// settling_time_s statistics over the runs that settled (None if none did).
    pub settling_time_s: Option<Stat>,
    /// saturated_fraction statistics.
    pub saturated_fraction: Stat,
}

/// Statistics of a sample (empty → None).
pub fn stat(v: &[f64]) -> Option<Stat> {
    if v.is_empty() {
        return None;
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = if v.len() > 1 {
        v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)
    } else {
        0.0
    };
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let rank = ((0.95 * n).ceil() as usize).clamp(1, s.len()) - 1;
    Some(Stat {
        mean,
        std: var.sqrt(),
        min: s[0],
        p95: s[rank],
        max: s[s.len() - 1],
    })
}

fn scaled(d: &DisturbanceSpec, k: f64) -> DisturbanceSpec {
    let mut d = *d;
    match &mut d {
        DisturbanceSpec::Torque { torque_n_m, .. } => *torque_n_m = torque_n_m.map(|v| v * k),
        DisturbanceSpec::TorqueGust { peak_n_m, .. } => *peak_n_m = peak_n_m.map(|v| v * k),
        DisturbanceSpec::Gust1Cos { velocity_m_s, .. } => *velocity_m_s = velocity_m_s.map(|v| v * k),
        DisturbanceSpec::Dryden { sigma_m_s, .. } => *sigma_m_s *= k.max(0.0),
        DisturbanceSpec::Pendulum { mass_kg, .. } | DisturbanceSpec::Payload { mass_kg, .. } => *mass_kg *= k.max(0.05),
    }
    d
}

/// One Monte Carlo run with index `i`.
pub fn run_one(scn: &Scenario, mc: &MonteCarloSpec, i: usize) -> Result<Metrics> {
    let seed = mc.seed.wrapping_add(i as u64);
    let mut rng = SmallRng::seed_from_u64(seed ^ 0x5eed_5eed);
    let nrm = Normal::new(0.0, 1.0).map_err(|e| SimError::Param(e.to_string()))?;
    let nominal = scn.vehicle.resolve()?;
    let mut spec = nominal;
    let b = spec.body_mut();
    b.mass_kg *= (1.0 + mc.mass_sd * nrm.sample(&mut rng)).max(0.2);
    for j in b.inertia_kg_m2.iter_mut() {
        *j *= (1.0 + mc.inertia_sd * nrm.sample(&mut rng)).max(0.2);
    }
    if let crate::vehicle::VehicleSpec::Bicopter(bc) = &mut spec {
        let r = bc.im_kg_m2 / bc.jx();
        let jx = bc.body.inertia_kg_m2[0];
        bc.im_kg_m2 = r * jx;
        bc.ib_kg_m2 = (1.0 - r) * jx;
    }
    let dist: Vec<DisturbanceSpec> = scn
        .disturbance
        .iter()
        .map(|d| scaled(d, 1.0 + mc.disturbance_sd * nrm.sample(&mut rng)))
        .collect();
    for d in &dist {
        if let DisturbanceSpec::Payload { mass_kg, position_m } = d {
            spec.add_point_mass(*mass_kg, *position_m);
        }
    }
    let mut sim = Simulation::with_vehicle(scn, spec.build()?, &nominal.build()?, &dist, seed)?;
    let every = log_every(scn)?;
    Ok(sim.run(scn.sim.duration_s, every, scn.sim.settle_band).1)
}

/// Runs the study in parallel (all rayon threads). `progress(done, total)` is called after each run,
/// from whichever thread finished it, so a caller can draw a progress bar; this crate prints nothing.
pub fn run(
    scn: &Scenario,
    mc: &MonteCarloSpec,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Vec<Metrics>, Summary)> {
    mc.validate()?;
    let indices: Vec<usize> = (0..mc.runs).collect();
    let all = run_indices(scn, mc, &indices, progress)?;
    let summary = summarize(&all);
    Ok((all, summary))
}

/// Runs the study's runs with the given indices (run i uses noise seed `mc.seed + i` and its own
/// sampled parameters, so any split of a campaign into index ranges gives the same runs as the
/// whole), in parallel on the current rayon pool; the metrics come back in the order of `indices`.
/// `mc.runs` is not consulted: indices beyond it are valid runs of a larger study.
///
/// # Errors
/// No index, a negative standard deviation, an invalid scenario, or a failed run.
pub fn run_indices(
    scn: &Scenario,
    mc: &MonteCarloSpec,
    indices: &[usize],
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<Metrics>> {
    if indices.is_empty() {
        return Err(SimError::Param("a Monte Carlo study needs at least one run".into()));
    }
    if indices.len() > MAX_RUNS {
        return Err(SimError::Param(format!(
            "{} runs asked for in one call, more than {MAX_RUNS}: split the campaign into ranges (--seeds A..B)",
            indices.len()
        )));
    }
    mc.validate_spreads()?;
    // Fail fast on a bad scenario before spawning work.
    Simulation::new(scn, mc.seed)?;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let total = indices.len();
    indices
        .par_iter()
        .map(|&i| {
            let r = run_one(scn, mc, i);
            progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1, total);
            r
        })
        .collect()
}

/// Summary statistics of a set of runs (in the order given; a merged campaign summarized in the
/// order of its indices equals the summary of one run over the same indices).
pub fn summarize(all: &[Metrics]) -> Summary {
    let col = |f: &dyn Fn(&Metrics) -> f64| all.iter().map(f).collect::<Vec<f64>>();
    let settled: Vec<f64> = all.iter().filter_map(|m| m.settling_time_s).collect();
    let empty = Stat {
        mean: 0.0,
        std: 0.0,
        min: 0.0,
        p95: 0.0,
        max: 0.0,
    };
    Summary {
        runs: all.len(),
        crashed: all.iter().filter(|m| m.crashed).count(),
        unsettled: all.len() - settled.len(),
        max_abs_error: stat(&col(&|m| m.max_abs_error)).unwrap_or(empty),
        rms_error: stat(&col(&|m| m.rms_error)).unwrap_or(empty),
        settling_time_s: stat(&settled),
        saturated_fraction: stat(&col(&|m| m.saturated_fraction)).unwrap_or(empty),
    }
}
