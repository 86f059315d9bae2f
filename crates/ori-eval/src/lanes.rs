//! Lanes of `f32` for the ray searches: [`Lanes`] is what the searches need, written once
//! over the lane count `W`; [`F4`] is four lanes (SSE registers on x86-64, where SSE2 is part
//! of the baseline; plain arrays elsewhere) and, on x86-64, [`F8`] eight lanes in AVX
//! registers, used only by code compiled with the `avx2` feature after runtime detection.
//! Every operation is one IEEE operation per lane, exactly as the scalar code does it (no
//! fused multiply-add, no approximations), so every form, and the scalar rule, agree bit for
//! bit.

/// `W` lanes of `f32`.
pub(crate) trait Lanes<const W: usize>: Copy {
    /// Per-lane booleans of the same width.
    type Mask: LaneMask<W>;
    fn splat(v: f32) -> Self;
    fn from_array(a: [f32; W]) -> Self;
    fn to_array(self) -> [f32; W];
    fn add(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    /// Lane-wise maximum of finite values (`self` where greater, else `o`).
    fn max(self, o: Self) -> Self;
    /// Lane-wise minimum of finite values (`self` where less, else `o`).
    fn min(self, o: Self) -> Self;
    fn le(self, o: Self) -> Self::Mask;
    fn ge(self, o: Self) -> Self::Mask;
    fn lt(self, o: Self) -> Self::Mask;
    /// `if m { a } else { b }` per lane.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// Truncation towards zero of values that fit `i32`.
    fn trunc(self) -> [i32; W];
}

/// `W` per-lane booleans.
pub(crate) trait LaneMask<const W: usize>: Copy {
    fn from_array(a: [bool; W]) -> Self;
    fn and(self, o: Self) -> Self;
    /// `self & !o`.
    fn and_not(self, o: Self) -> Self;
    fn any(self) -> bool;
    fn to_array(self) -> [bool; W];
}

/// [`Lanes`] and [`LaneMask`] on one x86 register type, from its intrinsics. SAFETY (every
/// `unsafe` it writes): the intrinsics need only the feature the register type belongs to,
/// which the code using the type is compiled with (SSE2: the x86-64 baseline; AVX: only
/// inside `#[target_feature(enable = "avx2")]` functions called after detection); loads and
/// stores go through arrays of `W` lanes.
#[cfg(target_arch = "x86_64")]
macro_rules! x86_lanes {
    (
        $F:ident, $M:ident, $W:literal, $reg:ty,
        set1 $set1:ident, load $load:ident, store $store:ident, add $add:ident, mul $mul:ident,
        sub $sub:ident, div $div:ident, max $max:ident, min $min:ident, and $and:ident,
        andnot $andnot:ident, or $or:ident, cvtt $cvtt:ident, store_int $store_int:ident,
        load_int $load_int:ident, cast $cast:ident, movemask $movemask:ident,
        le $le:expr, ge $ge:expr, lt $lt:expr $(,)?
    ) => {
        #[derive(Clone, Copy)]
        pub(crate) struct $F($reg);

        /// Per lane all ones (true) or all zeros (false).
        #[derive(Clone, Copy)]
        pub(crate) struct $M($reg);

        impl Lanes<$W> for $F {
            type Mask = $M;
            #[inline(always)]
            fn splat(v: f32) -> $F {
                $F(unsafe { $set1(v) })
            }
            #[inline(always)]
            fn from_array(a: [f32; $W]) -> $F {
                $F(unsafe { $load(a.as_ptr()) })
            }
            #[inline(always)]
            fn to_array(self) -> [f32; $W] {
                let mut out = [0.0f32; $W];
                unsafe { $store(out.as_mut_ptr(), self.0) };
                out
            }
            #[inline(always)]
            fn add(self, o: $F) -> $F {
                $F(unsafe { $add(self.0, o.0) })
            }
            #[inline(always)]
            fn mul(self, o: $F) -> $F {
                $F(unsafe { $mul(self.0, o.0) })
            }
            #[inline(always)]
            fn sub(self, o: $F) -> $F {
                $F(unsafe { $sub(self.0, o.0) })
            }
            #[inline(always)]
            fn div(self, o: $F) -> $F {
                $F(unsafe { $div(self.0, o.0) })
            }
            // `max` / `min` return the second operand unless the first is greater / less,
            // as the portable form does.
            #[inline(always)]
            fn max(self, o: $F) -> $F {
                $F(unsafe { $max(self.0, o.0) })
            }
            #[inline(always)]
            fn min(self, o: $F) -> $F {
                $F(unsafe { $min(self.0, o.0) })
            }
            #[inline(always)]
            fn le(self, o: $F) -> $M {
                $M(unsafe { $le(self.0, o.0) })
            }
            #[inline(always)]
            fn ge(self, o: $F) -> $M {
                $M(unsafe { $ge(self.0, o.0) })
            }
            #[inline(always)]
            fn lt(self, o: $F) -> $M {
                $M(unsafe { $lt(self.0, o.0) })
            }
            #[inline(always)]
            fn select(m: $M, a: $F, b: $F) -> $F {
                $F(unsafe { $or($and(m.0, a.0), $andnot(m.0, b.0)) })
            }
            #[inline(always)]
            fn trunc(self) -> [i32; $W] {
                let mut out = [0i32; $W];
                unsafe { $store_int(out.as_mut_ptr().cast(), $cvtt(self.0)) };
                out
            }
        }

        impl LaneMask<$W> for $M {
            #[inline(always)]
            fn from_array(a: [bool; $W]) -> $M {
                let bits = a.map(|b| if b { -1i32 } else { 0 });
                $M(unsafe { $cast($load_int(bits.as_ptr().cast())) })
            }
            #[inline(always)]
            fn and(self, o: $M) -> $M {
                $M(unsafe { $and(self.0, o.0) })
            }
            #[inline(always)]
            fn and_not(self, o: $M) -> $M {
                $M(unsafe { $andnot(o.0, self.0) })
            }
            #[inline(always)]
            fn any(self) -> bool {
                unsafe { $movemask(self.0) != 0 }
            }
            #[inline(always)]
            fn to_array(self) -> [bool; $W] {
                let bits = unsafe { $movemask(self.0) };
                std::array::from_fn(|l| bits >> l & 1 != 0)
            }
        }
    };
}

#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
mod sse {
    use super::{LaneMask, Lanes};
    use std::arch::x86_64::*;

    x86_lanes!(
        F4, M4, 4, __m128,
        set1 _mm_set1_ps, load _mm_loadu_ps, store _mm_storeu_ps, add _mm_add_ps,
        mul _mm_mul_ps, sub _mm_sub_ps, div _mm_div_ps, max _mm_max_ps, min _mm_min_ps,
        and _mm_and_ps, andnot _mm_andnot_ps, or _mm_or_ps, cvtt _mm_cvttps_epi32,
        store_int _mm_storeu_si128, load_int _mm_loadu_si128, cast _mm_castsi128_ps,
        movemask _mm_movemask_ps,
        le _mm_cmple_ps, ge _mm_cmpge_ps, lt _mm_cmplt_ps,
    );
}

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::{LaneMask, Lanes};
    use std::arch::x86_64::*;

    x86_lanes!(
        F8, M8, 8, __m256,
        set1 _mm256_set1_ps, load _mm256_loadu_ps, store _mm256_storeu_ps,
        add _mm256_add_ps, mul _mm256_mul_ps, sub _mm256_sub_ps, div _mm256_div_ps,
        max _mm256_max_ps, min _mm256_min_ps, and _mm256_and_ps, andnot _mm256_andnot_ps,
        or _mm256_or_ps, cvtt _mm256_cvttps_epi32, store_int _mm256_storeu_si256,
        load_int _mm256_loadu_si256, cast _mm256_castsi256_ps, movemask _mm256_movemask_ps,
        // Ordered, quiet: the results of SSE's `cmpleps` / `cmpltps` (which only signal
        // differently on NaN).
        le _mm256_cmp_ps::<_CMP_LE_OQ>, ge _mm256_cmp_ps::<_CMP_GE_OQ>,
        lt _mm256_cmp_ps::<_CMP_LT_OQ>,
    );
}

#[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
mod portable {
    use super::{LaneMask, Lanes};

    #[derive(Clone, Copy)]
    pub(crate) struct F4([f32; 4]);

    #[derive(Clone, Copy)]
    pub(crate) struct M4([bool; 4]);

    impl Lanes<4> for F4 {
        type Mask = M4;
        #[inline(always)]
        fn splat(v: f32) -> F4 {
            F4([v; 4])
        }
        #[inline(always)]
        fn from_array(a: [f32; 4]) -> F4 {
            F4(a)
        }
        #[inline(always)]
        fn to_array(self) -> [f32; 4] {
            self.0
        }
        #[inline(always)]
        fn add(self, o: F4) -> F4 {
            F4(std::array::from_fn(|i| self.0[i] + o.0[i]))
        }
        #[inline(always)]
        fn mul(self, o: F4) -> F4 {
            F4(std::array::from_fn(|i| self.0[i] * o.0[i]))
        }
        #[inline(always)]
        fn sub(self, o: F4) -> F4 {
            F4(std::array::from_fn(|i| self.0[i] - o.0[i]))
        }
        #[inline(always)]
        fn div(self, o: F4) -> F4 {
            F4(std::array::from_fn(|i| self.0[i] / o.0[i]))
        }
        #[inline(always)]
        fn max(self, o: F4) -> F4 {
            F4(std::array::from_fn(|i| {
                if self.0[i] > o.0[i] {
                    self.0[i]
                } else {
                    o.0[i]
                }
            }))
        }
        #[inline(always)]
        fn min(self, o: F4) -> F4 {
            F4(std::array::from_fn(|i| {
                if self.0[i] < o.0[i] {
                    self.0[i]
                } else {
                    o.0[i]
                }
            }))
        }
        #[inline(always)]
        fn le(self, o: F4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] <= o.0[i]))
        }
        #[inline(always)]
        fn ge(self, o: F4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] >= o.0[i]))
        }
        #[inline(always)]
        fn lt(self, o: F4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] < o.0[i]))
        }
        #[inline(always)]
        fn select(m: M4, a: F4, b: F4) -> F4 {
            F4(std::array::from_fn(
                |i| if m.0[i] { a.0[i] } else { b.0[i] },
            ))
        }
        #[inline(always)]
        fn trunc(self) -> [i32; 4] {
            self.0.map(|v| v as i32)
        }
    }

    impl LaneMask<4> for M4 {
        #[inline(always)]
        fn from_array(a: [bool; 4]) -> M4 {
            M4(a)
        }
        #[inline(always)]
        fn and(self, o: M4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] & o.0[i]))
        }
        #[inline(always)]
        fn and_not(self, o: M4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] & !o.0[i]))
        }
        #[inline(always)]
        fn any(self) -> bool {
            self.0.contains(&true)
        }
        #[inline(always)]
        fn to_array(self) -> [bool; 4] {
            self.0
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx::F8;
#[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
pub(crate) use portable::F4;
#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
pub(crate) use sse::F4;
