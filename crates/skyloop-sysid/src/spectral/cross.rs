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

    /// (G, γ²): open loop Φ_yu/Φ_uu; closed loop Φ_yr/Φ_ur with the combined coherence.
    pub fn response(&self, closed: bool) -> (C64, f64) {
        if !closed {
            let g = self.yu / self.uu;
            let coh = self.yu.norm_sqr() / (self.uu * self.yy);
            (g, coh)
        } else {
            let g = self.yr / self.ur;
            let c_yr = (self.yr.norm_sqr() / (self.yy * self.rr)).clamp(1e-12, 1.0);
            let c_ur = (self.ur.norm_sqr() / (self.uu * self.rr)).clamp(1e-12, 1.0);
            let coh = 1.0 / (1.0 / c_yr + 1.0 / c_ur - 1.0);
            (g, coh)
        }
    }
}
