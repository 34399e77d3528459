//! Auto and cross spectra at one frequency, and the response and coherence they give.

use num_complex::Complex64 as C64;

/// Φ_uu, Φ_yy, Φ_yu and, with an excitation, Φ_rr, Φ_ur, Φ_yr; with a measured disturbance d,
/// Φ_dd and Φ_ud, Φ_yd, Φ_rd (cross spectra as A·B̄).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Cross {
    pub uu: f64,
    pub yy: f64,
    pub yu: C64,
    pub rr: f64,
    pub ur: C64,
    pub yr: C64,
    pub dd: f64,
    pub ud: C64,
    pub yd: C64,
    pub rd: C64,
}

impl Cross {
    /// Adds w·(products of the DFT values u, y, r and d).
    #[inline]
    pub fn add(&mut self, w: f64, u: C64, y: C64, r: Option<C64>, d: Option<C64>) {
        self.uu += w * u.norm_sqr();
        self.yy += w * y.norm_sqr();
        self.yu += w * y * u.conj();
        if let Some(r) = r {
            self.rr += w * r.norm_sqr();
            self.ur += w * u * r.conj();
            self.yr += w * y * r.conj();
        }
        if let Some(d) = d {
            self.dd += w * d.norm_sqr();
            self.ud += w * u * d.conj();
            self.yd += w * y * d.conj();
            if let Some(r) = r {
                self.rd += w * r * d.conj();
            }
        }
    }

    /// Adds k·(every sum of `o`).
    pub fn add_scaled(&mut self, k: f64, o: &Cross) {
        self.uu += k * o.uu;
        self.yy += k * o.yy;
        self.yu += k * o.yu;
        self.rr += k * o.rr;
        self.ur += k * o.ur;
        self.yr += k * o.yr;
        self.dd += k * o.dd;
        self.ud += k * o.ud;
        self.yd += k * o.yd;
        self.rd += k * o.rd;
    }

    /// The spectra of u, y and r conditioned on the measured disturbance d (Bendat & Piersol's
    /// conditioned spectra Φ_ab·d = Φ_ab − Φ_ad·Φ_db/Φ_dd): what is left of each signal once its
    /// linear dependence on d is removed. Unchanged without a disturbance (Φ_dd = 0).
    pub fn conditioned(&self) -> Cross {
        if !(self.dd > 0.0) {
            return *self;
        }
        let dd = self.dd;
        // Φ_ab·d = Φ_ab − Φ_ad·conj(Φ_bd)/Φ_dd, with Φ_ad = E[A·D̄].
        let cond = |ab: C64, ad: C64, bd: C64| ab - ad * bd.conj() / dd;
        Cross {
            uu: (self.uu - self.ud.norm_sqr() / dd).max(0.0),
            yy: (self.yy - self.yd.norm_sqr() / dd).max(0.0),
            yu: cond(self.yu, self.yd, self.ud),
            rr: (self.rr - self.rd.norm_sqr() / dd).max(0.0),
            ur: cond(self.ur, self.ud, self.rd),
            yr: cond(self.yr, self.yd, self.rd),
            ..Cross::default()
        }
    }

    /// (G, γ²): open loop Φ_yu/Φ_uu; closed loop Φ_yr/Φ_ur with the signal-to-noise coherence; with
    /// a measured disturbance d, the same of the spectra conditioned on d ([`Cross::conditioned`]),
    /// which is the two-input estimate y = G·u + H·d + v solved for G (d its own instrument).
    pub fn response(&self, closed: bool) -> (C64, f64) {
        let c = self.conditioned();
        if !closed {
            let g = c.yu / c.uu;
            let coh = c.yu.norm_sqr() / (c.uu * c.yy);
            (g, coh)
        } else {
            let g = c.yr / c.ur;
            // Noise spectrum of y = G·u + v from the residual e = y − Ĝ·u, and the part of u driven by r.
            let vv = (c.yy - 2.0 * (g.conj() * c.yu).re + g.norm_sqr() * c.uu).max(0.0);
            let u_r = c.ur.norm_sqr() / c.rr;
            let signal = g.norm_sqr() * u_r;
            let coh = signal / (signal + vv);
            (g, coh)
        }
    }
}
