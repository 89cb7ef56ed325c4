//! Interval arithmetic, enough to enclose OpenCV's distortion polynomial over a rectangle of
//! normalized coordinates. Every operation returns an interval containing all results of the
//! operation on members of its operands; f64 rounding is covered by the caller's margin.

/// A closed interval `[lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Interval {
    pub lo: f64,
    pub hi: f64,
}

impl Interval {
    pub fn new(lo: f64, hi: f64) -> Self {
        Interval { lo, hi }
    }

    pub fn point(v: f64) -> Self {
        Interval { lo: v, hi: v }
    }

    pub fn add(self, o: Interval) -> Interval {
        Interval::new(self.lo + o.lo, self.hi + o.hi)
    }

    pub fn mul(self, o: Interval) -> Interval {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        Interval::new(
            p.iter().copied().fold(f64::INFINITY, f64::min),
            p.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    }

    pub fn scale(self, k: f64) -> Interval {
        if k >= 0.0 {
            Interval::new(self.lo * k, self.hi * k)
        } else {
            Interval::new(self.hi * k, self.lo * k)
        }
    }

    /// `x²`, tight (non-negative, zero inside when the interval straddles 0).
    pub fn square(self) -> Interval {
        let (a, b) = (self.lo * self.lo, self.hi * self.hi);
        if self.lo <= 0.0 && self.hi >= 0.0 {
            Interval::new(0.0, a.max(b))
        } else {
            Interval::new(a.min(b), a.max(b))
        }
    }

    /// `self / o`, or `None` when `o` contains zero.
    pub fn div(self, o: Interval) -> Option<Interval> {
        if o.lo <= 0.0 && o.hi >= 0.0 {
            return None;
        }
        Some(self.mul(Interval::new(1.0 / o.hi, 1.0 / o.lo)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn operations_enclose_every_result() {
        let a = Interval::new(-1.5, 2.0);
        let b = Interval::new(0.5, 3.0);
        let samples = |i: Interval| (0..=20).map(move |k| i.lo + (i.hi - i.lo) * k as f64 / 20.0);
        for x in samples(a) {
            assert!(a.square().lo <= x * x && x * x <= a.square().hi);
            for y in samples(b) {
                let (m, d) = (a.mul(b), a.div(b).unwrap());
                assert!(m.lo <= x * y && x * y <= m.hi);
                assert!(d.lo <= x / y + 1e-12 && x / y <= d.hi + 1e-12);
                let s = a.add(b).scale(-2.0);
                assert!(s.lo <= -2.0 * (x + y) && -2.0 * (x + y) <= s.hi);
            }
        }
        assert!(b.div(a).is_none());
        assert_eq!(Interval::new(-1.0, 2.0).square(), Interval::new(0.0, 4.0));
    }
}
