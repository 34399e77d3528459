//! Auto and cross spectra at one frequency, and the response and coherence they give.

use num_complex::Complex64 as C64;

/// Φ_uu, Φ_yy, Φ_yu and, with an excitation, Φ_rr, Φ_ur, Φ_yr (cross spectra as A·B̄).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Cross {
    pub uu: f64,
    pub yy: f64,
    pub yu: C64,
    pub rr: f64,
    pub ur: C64,
    pub yr: C64,
}

impl Cross {
    /// Adds w·(products of the DFT values u, y, r).
    #[inline]
    pub fn add(&mut self, w: f64, u: C64, y: C64, r: Option<C64>) {
        self.uu += w * u.norm_sqr();
        self.yy += w * y.norm_sqr();
        self.yu += w * y * u.conj();
        if let Some(r) = r {
            self.rr += w * r.norm_sqr();
            self.ur += w * u * r.conj();
            self.yr += w * y * r.conj();
        }
    }

    /// (G, γ²): open loop Φ_yu/Φ_uu; closed loop Φ_yr/Φ_ur with the signal-to-noise coherence.
    pub fn response(&self, closed: bool) -> (C64, f64) {
        if !closed {
            let g = self.yu / self.uu;
            let coh = self.yu.norm_sqr() / (self.uu * self.yy);
            (g, coh)
        } else {
            let g = self.yr / self.ur;
            // Noise spectrum of y = G·u + v from the residual e = y − Ĝ·u, and the part of u driven by r.
            let vv = (self.yy - 2.0 * (g.conj() * self.yu).re + g.norm_sqr() * self.uu).max(0.0);
            let u_r = self.ur.norm_sqr() / self.rr;
            let signal = g.norm_sqr() * u_r;
            let coh = signal / (signal + vv);
            (g, coh)
        }
    }
}
