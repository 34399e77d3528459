//! Test-only helpers: a sampled-data simulation of a continuous plant with an exact input delay.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure
#![allow(dead_code)]

use skyloop_lti::expr::parse_model;

/// A continuous plant (rational part from an expression, plus an input delay) integrated exactly
/// for piecewise-constant inputs on a fine step h (ZOH discretization by a Taylor series of the
/// augmented matrix [[A, B], [0, 0]]·h, whose norm is small for the fine step).
pub struct Plant {
    phi: Vec<Vec<f64>>,
    gam: Vec<f64>,
    c: Vec<f64>,
    d: f64,
    x: Vec<f64>,
    delay_line: std::collections::VecDeque<f64>,
    /// Fine integration step, s.
    pub h: f64,
}

impl Plant {
    pub fn new(rational: &str, delay_s: f64, h: f64) -> Plant {
        let ss = parse_model(rational).unwrap();
        let n = ss.nx();
        let m = n + 1;
        let mut aug = vec![vec![0.0; m]; m];
        for i in 0..n {
            for j in 0..n {
                aug[i][j] = ss.a[(i, j)] * h;
            }
            aug[i][n] = ss.b[(i, 0)] * h;
        }
        // exp(aug) = Σ aug^k/k!
        let mut e = vec![vec![0.0; m]; m];
        let mut term = vec![vec![0.0; m]; m];
        for i in 0..m {
            e[i][i] = 1.0;
            term[i][i] = 1.0;
        }
        for k in 1..30 {
            let mut next = vec![vec![0.0; m]; m];
            for i in 0..m {
                for j in 0..m {
                    next[i][j] = (0..m).map(|l| term[i][l] * aug[l][j]).sum::<f64>() / k as f64;
                }
            }
            term = next;
            for i in 0..m {
                for j in 0..m {
                    e[i][j] += term[i][j];
                }
            }
        }
        let phi = (0..n).map(|i| (0..n).map(|j| e[i][j]).collect()).collect();
        let gam = (0..n).map(|i| e[i][n]).collect();
        let steps = (delay_s / h).round() as usize;
        Plant {
            phi,
            gam,
            c: (0..n).map(|j| ss.c[(0, j)]).collect(),
            d: ss.d[(0, 0)],
            x: vec![0.0; n],
            delay_line: std::iter::repeat_n(0.0, steps).collect(),
            h,
        }
    }

    /// Current output (before the next input is applied).
    pub fn output(&self, u_now: f64) -> f64 {
        let ud = self.delay_line.front().copied().unwrap_or(u_now);
        self.c.iter().zip(&self.x).map(|(c, x)| c * x).sum::<f64>() + self.d * ud
    }

    /// Advances one fine step with input u held.
    pub fn step(&mut self, u: f64) {
        self.delay_line.push_back(u);
        let ud = self.delay_line.pop_front().unwrap_or(u);
        let n = self.x.len();
        let x: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| self.phi[i][j] * self.x[j]).sum::<f64>() + self.gam[i] * ud)
            .collect();
        self.x = x;
    }
}

/// The bicopter paper's servo experiment (Section III-A, eq. (6): 0.764·e^(−0.03 s)/(0.0332 s + 1)):
/// an exponential chirp 0.8–20 Hz for 40 s logged at 1/`dt_s`, plant integrated on `sub` fine steps per
/// sample, white output noise of `noise_std` from `seed`. Returns (u, y).
pub fn servo_experiment(dt_s: f64, sub: usize, noise_std: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use skyloop_sysid::signal::{chirp, ChirpSpec, Sweep};
    let mut plant = Plant::new("0.764/(0.0332*s+1)", 0.03, dt_s / sub as f64);
    let spec = ChirpSpec {
        f0_hz: 0.8,
        f1_hz: 20.0,
        duration_s: 40.0,
        amplitude: 1.0,
        amplitude_end: None,
        fade_s: 0.5,
        sweep: Sweep::Exponential,
    };
    let u = chirp(&spec, 1.0 / dt_s).unwrap().values;
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let noise = Normal::new(0.0, noise_std).unwrap();
    let mut y = Vec::with_capacity(u.len());
    for &uk in &u {
        y.push(plant.output(0.0) + noise.sample(&mut rng));
        for _ in 0..sub {
            plant.step(uk);
        }
    }
    (u, y)
}
