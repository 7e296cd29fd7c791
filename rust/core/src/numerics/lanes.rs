//! Four f64 lanes as one value, for the lane-split sums of the kernels.
//!
//! The kernels accumulate in four interleaved lanes (lane k takes the
//! samples i with i % 4 == k) so that they vectorise while the order of
//! every addition stays fixed. With several accumulators in one loop,
//! LLVM's auto-vectoriser pairs lanes of different accumulators and spills
//! (measured: 3x slower than this module). These types spell the vectors
//! out: one AVX register, two SSE2 registers, or a plain array. Each does
//! exactly the same IEEE operations per lane (no FMA), so all three give
//! the same bits; only the speed differs.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// Four f64 lanes.
pub(crate) trait F4: Copy {
    fn zero() -> Self;
    fn splat(v: f64) -> Self;
    /// The first four values of `s` (at least four long).
    fn load(s: &[f64]) -> Self;
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn to_array(self) -> [f64; 4];

    /// (l0 + l1) + (l2 + l3): how every lane-split sum is folded.
    #[inline(always)]
    fn fold(self) -> f64 {
        let a = self.to_array();
        (a[0] + a[1]) + (a[2] + a[3])
    }
}

/// Portable lanes: a plain array.
#[derive(Clone, Copy)]
#[allow(dead_code)] // only used off x86-64
pub(crate) struct Scalar([f64; 4]);

impl F4 for Scalar {
    #[inline(always)]
    fn zero() -> Self {
        Scalar([0.0; 4])
    }
    #[inline(always)]
    fn splat(v: f64) -> Self {
        Scalar([v; 4])
    }
    #[inline(always)]
    fn load(s: &[f64]) -> Self {
        Scalar([s[0], s[1], s[2], s[3]])
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Scalar([self.0[0] + o.0[0], self.0[1] + o.0[1], self.0[2] + o.0[2], self.0[3] + o.0[3]])
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Scalar([self.0[0] - o.0[0], self.0[1] - o.0[1], self.0[2] - o.0[2], self.0[3] - o.0[3]])
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Scalar([self.0[0] * o.0[0], self.0[1] * o.0[1], self.0[2] * o.0[2], self.0[3] * o.0[3]])
    }
    #[inline(always)]
    fn to_array(self) -> [f64; 4] {
        self.0
    }
}

/// Two SSE2 registers (lanes 0-1 and 2-3); SSE2 is part of x86-64.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct Sse2(__m128d, __m128d);

// SAFETY (every block below): SSE2 is in the x86-64 baseline, so these
// intrinsics run on every CPU this code is compiled for; loads read four
// values from a slice checked to hold them.
#[cfg(target_arch = "x86_64")]
#[allow(unused_unsafe)]
impl F4 for Sse2 {
    #[inline(always)]
    fn zero() -> Self {
        unsafe { Sse2(_mm_setzero_pd(), _mm_setzero_pd()) }
    }
    #[inline(always)]
    fn splat(v: f64) -> Self {
        unsafe { Sse2(_mm_set1_pd(v), _mm_set1_pd(v)) }
    }
    #[inline(always)]
    fn load(s: &[f64]) -> Self {
        let s = &s[..4];
        unsafe { Sse2(_mm_loadu_pd(s.as_ptr()), _mm_loadu_pd(s.as_ptr().add(2))) }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        unsafe { Sse2(_mm_add_pd(self.0, o.0), _mm_add_pd(self.1, o.1)) }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        unsafe { Sse2(_mm_sub_pd(self.0, o.0), _mm_sub_pd(self.1, o.1)) }
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        unsafe { Sse2(_mm_mul_pd(self.0, o.0), _mm_mul_pd(self.1, o.1)) }
    }
    #[inline(always)]
    fn to_array(self) -> [f64; 4] {
        let mut a = [0.0; 4];
        unsafe {
            _mm_storeu_pd(a.as_mut_ptr(), self.0);
            _mm_storeu_pd(a.as_mut_ptr().add(2), self.1);
        }
        a
    }
}

/// One AVX register. Only for code inside a function compiled with
/// `#[target_feature(enable = "avx2")]` and called after run-time
/// detection: that is what makes the intrinsics below sound.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct Avx(__m256d);

// SAFETY (every block below): see the type's comment; loads read four
// values from a slice checked to hold them.
#[cfg(target_arch = "x86_64")]
#[allow(unused_unsafe)]
impl F4 for Avx {
    #[inline(always)]
    fn zero() -> Self {
        unsafe { Avx(_mm256_setzero_pd()) }
    }
    #[inline(always)]
    fn splat(v: f64) -> Self {
        unsafe { Avx(_mm256_set1_pd(v)) }
    }
    #[inline(always)]
    fn load(s: &[f64]) -> Self {
        let s = &s[..4];
        unsafe { Avx(_mm256_loadu_pd(s.as_ptr())) }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        unsafe { Avx(_mm256_add_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        unsafe { Avx(_mm256_sub_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        unsafe { Avx(_mm256_mul_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn to_array(self) -> [f64; 4] {
        let mut a = [0.0; 4];
        unsafe { _mm256_storeu_pd(a.as_mut_ptr(), self.0) };
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kernel<V: F4>(x: &[f64]) -> [f64; 4] {
        let m = V::splat(0.25);
        let mut a = V::zero();
        for c in x.chunks_exact(4) {
            let d = V::load(c).sub(m);
            a = a.add(d.mul(d));
        }
        a.to_array()
    }

    #[test]
    fn all_lane_types_give_the_same_bits() {
        let x: Vec<f64> = (0..4003).map(|i| (i as f64 * 0.37).sin() * 1e3 + 1.0 / (i as f64 + 1.0)).collect();
        let want = kernel::<Scalar>(&x);
        #[cfg(target_arch = "x86_64")]
        {
            assert_eq!(kernel::<Sse2>(&x), want);
            if std::arch::is_x86_feature_detected!("avx2") {
                #[target_feature(enable = "avx2")]
                unsafe fn avx(x: &[f64]) -> [f64; 4] {
                    kernel::<Avx>(x)
                }
                // SAFETY: AVX2 detected just above.
                assert_eq!(unsafe { avx(&x) }, want);
            }
        }
    }
}
