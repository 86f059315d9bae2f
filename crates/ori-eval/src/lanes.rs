//! Four `f32` lanes for the ray searches. On x86-64 they are SSE registers (SSE2 is part of
//! the x86-64 baseline, so there is no runtime detection); elsewhere plain arrays. Every
//! operation is one IEEE operation per lane, exactly as the scalar code does it (no fused
//! multiply-add, no approximations), so both forms, and the scalar rule, agree bit for bit.

#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
mod imp {
    // SAFETY (every `unsafe` below): the SSE2 intrinsics need only the `sse2` target feature,
    // which this module is compiled with; loads and stores go through arrays of four lanes.
    use std::arch::x86_64::*;

    #[derive(Clone, Copy)]
    pub(crate) struct F4(__m128);

    /// Per lane all ones (true) or all zeros (false).
    #[derive(Clone, Copy)]
    pub(crate) struct M4(__m128);

    impl F4 {
        #[inline(always)]
        pub fn splat(v: f32) -> F4 {
            F4(unsafe { _mm_set1_ps(v) })
        }

        #[inline(always)]
        pub fn from_array(a: [f32; 4]) -> F4 {
            F4(unsafe { _mm_loadu_ps(a.as_ptr()) })
        }

        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            let mut out = [0.0f32; 4];
            unsafe { _mm_storeu_ps(out.as_mut_ptr(), self.0) };
            out
        }

        #[inline(always)]
        pub fn add(self, o: F4) -> F4 {
            F4(unsafe { _mm_add_ps(self.0, o.0) })
        }

        #[inline(always)]
        pub fn mul(self, o: F4) -> F4 {
            F4(unsafe { _mm_mul_ps(self.0, o.0) })
        }

        #[inline(always)]
        pub fn sub(self, o: F4) -> F4 {
            F4(unsafe { _mm_sub_ps(self.0, o.0) })
        }

        #[inline(always)]
        pub fn div(self, o: F4) -> F4 {
            F4(unsafe { _mm_div_ps(self.0, o.0) })
        }

        #[inline(always)]
        pub fn le(self, o: F4) -> M4 {
            M4(unsafe { _mm_cmple_ps(self.0, o.0) })
        }

        /// Lane-wise maximum of finite values.
        #[inline(always)]
        pub fn max(self, o: F4) -> F4 {
            F4(unsafe { _mm_max_ps(self.0, o.0) })
        }

        /// Lane-wise minimum of finite values.
        #[inline(always)]
        pub fn min(self, o: F4) -> F4 {
            F4(unsafe { _mm_min_ps(self.0, o.0) })
        }

        #[inline(always)]
        pub fn ge(self, o: F4) -> M4 {
            M4(unsafe { _mm_cmpge_ps(self.0, o.0) })
        }

        #[inline(always)]
        pub fn lt(self, o: F4) -> M4 {
            M4(unsafe { _mm_cmplt_ps(self.0, o.0) })
        }

        /// `if m { a } else { b }` per lane.
        #[inline(always)]
        pub fn select(m: M4, a: F4, b: F4) -> F4 {
            F4(unsafe { _mm_or_ps(_mm_and_ps(m.0, a.0), _mm_andnot_ps(m.0, b.0)) })
        }

        /// Truncation towards zero of values that fit `i32`.
        #[inline(always)]
        pub fn trunc(self) -> [i32; 4] {
            let mut out = [0i32; 4];
            unsafe { _mm_storeu_si128(out.as_mut_ptr().cast(), _mm_cvttps_epi32(self.0)) };
            out
        }
    }

    impl M4 {
        #[inline(always)]
        pub fn from_array(a: [bool; 4]) -> M4 {
            let bits = a.map(|b| if b { -1i32 } else { 0 });
            M4(unsafe { _mm_castsi128_ps(_mm_loadu_si128(bits.as_ptr().cast())) })
        }

        #[inline(always)]
        pub fn and(self, o: M4) -> M4 {
            M4(unsafe { _mm_and_ps(self.0, o.0) })
        }

        /// `self & !o`.
        #[inline(always)]
        pub fn and_not(self, o: M4) -> M4 {
            M4(unsafe { _mm_andnot_ps(o.0, self.0) })
        }

        #[inline(always)]
        pub fn any(self) -> bool {
            unsafe { _mm_movemask_ps(self.0) != 0 }
        }

        #[inline(always)]
        pub fn to_array(self) -> [bool; 4] {
            let bits = unsafe { _mm_movemask_ps(self.0) };
            std::array::from_fn(|l| bits >> l & 1 != 0)
        }
    }
}

#[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
mod imp {
    #[derive(Clone, Copy)]
    pub(crate) struct F4([f32; 4]);

    #[derive(Clone, Copy)]
    pub(crate) struct M4([bool; 4]);

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
            F4(std::array::from_fn(|i| self.0[i] + o.0[i]))
        }

        #[inline(always)]
        pub fn mul(self, o: F4) -> F4 {
            F4(std::array::from_fn(|i| self.0[i] * o.0[i]))
        }

        #[inline(always)]
        pub fn sub(self, o: F4) -> F4 {
            F4(std::array::from_fn(|i| self.0[i] - o.0[i]))
        }

        #[inline(always)]
        pub fn div(self, o: F4) -> F4 {
            F4(std::array::from_fn(|i| self.0[i] / o.0[i]))
        }

        #[inline(always)]
        pub fn le(self, o: F4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] <= o.0[i]))
        }

        #[inline(always)]
        pub fn max(self, o: F4) -> F4 {
            F4(std::array::from_fn(|i| {
                if self.0[i] > o.0[i] {
                    self.0[i]
                } else {
                    o.0[i]
                }
            }))
        }

        #[inline(always)]
        pub fn min(self, o: F4) -> F4 {
            F4(std::array::from_fn(|i| {
                if self.0[i] < o.0[i] {
                    self.0[i]
                } else {
                    o.0[i]
                }
            }))
        }

        #[inline(always)]
        pub fn ge(self, o: F4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] >= o.0[i]))
        }

        #[inline(always)]
        pub fn lt(self, o: F4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] < o.0[i]))
        }

        #[inline(always)]
        pub fn select(m: M4, a: F4, b: F4) -> F4 {
            F4(std::array::from_fn(
                |i| if m.0[i] { a.0[i] } else { b.0[i] },
            ))
        }

        #[inline(always)]
        pub fn trunc(self) -> [i32; 4] {
            self.0.map(|v| v as i32)
        }
    }

    impl M4 {
        #[inline(always)]
        pub fn from_array(a: [bool; 4]) -> M4 {
            M4(a)
        }

        #[inline(always)]
        pub fn and(self, o: M4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] & o.0[i]))
        }

        #[inline(always)]
        pub fn and_not(self, o: M4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] & !o.0[i]))
        }

        #[inline(always)]
        pub fn any(self) -> bool {
            self.0.contains(&true)
        }

        #[inline(always)]
        pub fn to_array(self) -> [bool; 4] {
            self.0
        }
    }
}

pub(crate) use imp::{F4, M4};
