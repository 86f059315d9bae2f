//! Four `f32` lanes for the per-block loops. On x86-64 they are SSE registers (SSE2 is part
//! of the x86-64 baseline, so there is no runtime feature detection); elsewhere plain arrays.
//! Every operation is one IEEE operation per lane (no fused multiply-add, no approximate
//! reciprocals), so both forms give bit-identical results.

use std::ops::{Add, Mul, Sub};

#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
mod imp {
    // SAFETY (every `unsafe` below): the SSE2 intrinsics need only the `sse2` target feature,
    // which this module is compiled with (it is part of the x86-64 baseline).
    use std::arch::x86_64::*;

    #[derive(Clone, Copy, Debug)]
    pub(crate) struct F4(__m128);

    impl F4 {
        #[inline(always)]
        pub fn splat(v: f32) -> F4 {
            F4(unsafe { _mm_set1_ps(v) })
        }

        #[inline(always)]
        pub fn from_array(a: [f32; 4]) -> F4 {
            F4(unsafe { _mm_setr_ps(a[0], a[1], a[2], a[3]) })
        }

        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            let mut out = [0.0f32; 4];
            // `out` has room for the four lanes; unaligned stores are allowed.
            unsafe { _mm_storeu_ps(out.as_mut_ptr(), self.0) };
            out
        }

        #[inline(always)]
        pub fn add(self, o: F4) -> F4 {
            F4(unsafe { _mm_add_ps(self.0, o.0) })
        }

        #[inline(always)]
        pub fn sub(self, o: F4) -> F4 {
            F4(unsafe { _mm_sub_ps(self.0, o.0) })
        }

        #[inline(always)]
        pub fn mul(self, o: F4) -> F4 {
            F4(unsafe { _mm_mul_ps(self.0, o.0) })
        }

        /// Lane-wise minimum (operands are never NaN here).
        #[inline(always)]
        pub fn min(self, o: F4) -> F4 {
            F4(unsafe { _mm_min_ps(self.0, o.0) })
        }

        /// Lane-wise maximum (operands are never NaN here).
        #[inline(always)]
        pub fn max(self, o: F4) -> F4 {
            F4(unsafe { _mm_max_ps(self.0, o.0) })
        }
    }
}

#[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
mod imp {
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct F4([f32; 4]);

    impl F4 {
        #[inline(always)]
        pub fn splat(v: f32) -> F4 {
            F4([v; 4])
        }

        #[inline(always)]
        pub fn from_array(a: [f32; 4]) -> F4 {
            F4(a)
        }

        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            self.0
        }

        #[inline(always)]
        pub fn add(self, o: F4) -> F4 {
            F4(std::array::from_fn(|l| self.0[l] + o.0[l]))
        }

        #[inline(always)]
        pub fn sub(self, o: F4) -> F4 {
            F4(std::array::from_fn(|l| self.0[l] - o.0[l]))
        }

        #[inline(always)]
        pub fn mul(self, o: F4) -> F4 {
            F4(std::array::from_fn(|l| self.0[l] * o.0[l]))
        }

        #[inline(always)]
        pub fn min(self, o: F4) -> F4 {
            F4(std::array::from_fn(|l| {
                if self.0[l] < o.0[l] {
                    self.0[l]
                } else {
                    o.0[l]
                }
            }))
        }

        #[inline(always)]
        pub fn max(self, o: F4) -> F4 {
            F4(std::array::from_fn(|l| {
                if self.0[l] > o.0[l] {
                    self.0[l]
                } else {
                    o.0[l]
                }
            }))
        }
    }
}

pub(crate) use imp::F4;

impl F4 {
    /// Lanes `4 j .. 4 j + 4` of a block's 16 values.
    #[inline(always)]
    pub fn load(values: &[f32; 16], j: usize) -> F4 {
        F4::from_array([
            values[4 * j],
            values[4 * j + 1],
            values[4 * j + 2],
            values[4 * j + 3],
        ])
    }

    /// Clamps each lane to `[lo, hi]`.
    #[inline(always)]
    pub fn clamp(self, lo: f32, hi: f32) -> F4 {
        self.max(F4::splat(lo)).min(F4::splat(hi))
    }

    /// Rounds non-negative lanes below 2^23 to the nearest integer (ties to even) with two
    /// IEEE additions.
    #[inline(always)]
    pub fn round_small(self) -> F4 {
        const MAGIC: f32 = 8_388_608.0;
        (self + F4::splat(MAGIC)) - F4::splat(MAGIC)
    }

    /// Sum of the lanes in a fixed order.
    #[inline(always)]
    pub fn sum(self) -> f32 {
        let a = self.to_array();
        (a[0] + a[1]) + (a[2] + a[3])
    }
}

impl Add for F4 {
    type Output = F4;
    #[inline(always)]
    fn add(self, o: F4) -> F4 {
        F4::add(self, o)
    }
}

impl Sub for F4 {
    type Output = F4;
    #[inline(always)]
    fn sub(self, o: F4) -> F4 {
        F4::sub(self, o)
    }
}

impl Mul for F4 {
    type Output = F4;
    #[inline(always)]
    fn mul(self, o: F4) -> F4 {
        F4::mul(self, o)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_round_and_sum_in_order() {
        let v = F4::from_array([0.5, 1.5, 2.49, 3.7])
            .clamp(0.0, 3.0)
            .round_small();
        assert_eq!(v.to_array(), [0.0, 2.0, 2.0, 3.0]);
        assert_eq!(F4::from_array([1.0, 2.0, 3.0, 4.0]).sum(), 10.0);
    }
}
