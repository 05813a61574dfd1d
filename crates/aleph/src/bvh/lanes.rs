//! The SIMD lanes the BVH is generic over: glam's `Vec4` (SSE on x86-64, NEON on AArch64) for
//! four-wide nodes and leaves, and on x86-64 CPUs with AVX2 an eight-lane `F8` for eight-wide
//! ones. Both run the same traversal code with the same operations in the same order (no fused
//! multiply–add), so a triangle's t and barycentrics come out bit-identical at either width.

use glam::Vec4;
use std::ops::BitAnd;

/// A vector of [`Lanes::N`] `f32` lanes with the operations of the slab and triangle tests.
pub(crate) trait Lanes: Copy {
    /// Number of lanes (children per node, triangles per pack).
    const N: usize;
    /// A lane mask from a comparison.
    type Mask: Copy + BitAnd<Output = Self::Mask>;
    /// Child slots or triangle ids, one per lane.
    type Ids: Copy + AsRef<[u32]> + AsMut<[u32]>;
    /// Every id set to `v`.
    fn ids(v: u32) -> Self::Ids;
    /// Every lane set to `v`.
    fn splat(v: f32) -> Self;
    /// Lanes from the first [`Lanes::N`] values of `v`.
    ///
    /// # Panics
    /// If `v` holds fewer than [`Lanes::N`] values.
    fn from_slice(v: &[f32]) -> Self;
    /// Lane `i` (< [`Lanes::N`]).
    fn lane(self, i: usize) -> f32;
    /// Lane-wise `self + o`, IEEE single precision (no fused multiply–add anywhere).
    fn add(self, o: Self) -> Self;
    /// Lane-wise `self − o`.
    fn sub(self, o: Self) -> Self;
    /// Lane-wise `self × o`.
    fn mul(self, o: Self) -> Self;
    /// Lane-wise `self / o`, correctly rounded.
    fn div(self, o: Self) -> Self;
    /// Lane-wise −self (the sign bit flipped).
    fn neg(self) -> Self;
    /// Lane-wise minimum (`min(self, o)` with the SSE rule: `o` where either is NaN).
    fn min(self, o: Self) -> Self;
    /// Lane-wise maximum (the same NaN rule).
    fn max(self, o: Self) -> Self;
    /// Ordered comparisons (false where either is NaN): `self > o`.
    fn gt(self, o: Self) -> Self::Mask;
    /// `self < o`.
    fn lt(self, o: Self) -> Self::Mask;
    /// `self ≥ o`.
    fn ge(self, o: Self) -> Self::Mask;
    /// `self ≤ o`.
    fn le(self, o: Self) -> Self::Mask;
    /// Bit i set where lane i of the mask is true.
    fn bitmask(m: Self::Mask) -> u32;
}

impl Lanes for Vec4 {
    const N: usize = 4;
    type Mask = glam::BVec4A;
    type Ids = [u32; 4];
    #[inline(always)]
    fn ids(v: u32) -> [u32; 4] {
        [v; 4]
    }
    #[inline(always)]
    fn splat(v: f32) -> Self {
        Vec4::splat(v)
    }
    #[inline(always)]
    fn from_slice(v: &[f32]) -> Self {
        Vec4::from_slice(v)
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        self[i]
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        self + o
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        self - o
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        self * o
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        self / o
    }
    #[inline(always)]
    fn neg(self) -> Self {
        -self
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        Vec4::min(self, o)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Vec4::max(self, o)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self::Mask {
        self.cmpgt(o)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Self::Mask {
        self.cmplt(o)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Self::Mask {
        self.cmpge(o)
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self::Mask {
        self.cmple(o)
    }
    #[inline(always)]
    fn bitmask(m: Self::Mask) -> u32 {
        m.bitmask()
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx::{F8, has_avx2};

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::Lanes;
    use std::arch::x86_64::*;
    use std::ops::BitAnd;

    /// Eight `f32` lanes in an AVX register.
    ///
    /// Every method calls AVX intrinsics: an `F8` may only be made and used on a CPU that has
    /// AVX2 ([`has_avx2`]). The BVH builds eight-wide trees only there, and its traversal runs
    /// inside functions compiled for AVX2, where these methods inline.
    #[derive(Clone, Copy)]
    #[repr(transparent)]
    pub(crate) struct F8(__m256);

    /// True when this CPU has AVX2 (checked once by the standard library, then cached).
    pub(crate) fn has_avx2() -> bool {
        std::arch::is_x86_feature_detected!("avx2")
    }

    impl BitAnd for F8 {
        type Output = F8;
        #[inline(always)]
        fn bitand(self, o: F8) -> F8 {
            // SAFETY: `F8` exists only on CPUs with AVX2 (type invariant).
            F8(unsafe { _mm256_and_ps(self.0, o.0) })
        }
    }

    // SAFETY (every `unsafe` block below): `F8` values exist only on CPUs with AVX2 (the type's
    // invariant), and the loads read exactly 8 lanes from slices checked to hold them.
    impl Lanes for F8 {
        const N: usize = 8;
        type Mask = F8;
        type Ids = [u32; 8];
        #[inline(always)]
        fn ids(v: u32) -> [u32; 8] {
            [v; 8]
        }
        #[inline(always)]
        fn splat(v: f32) -> Self {
            F8(unsafe { _mm256_set1_ps(v) })
        }
        #[inline(always)]
        fn from_slice(v: &[f32]) -> Self {
            assert!(v.len() >= 8);
            F8(unsafe { _mm256_loadu_ps(v.as_ptr()) })
        }
        #[inline(always)]
        fn lane(self, i: usize) -> f32 {
            let mut out = [0f32; 8];
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) };
            out[i]
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            F8(unsafe { _mm256_add_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            F8(unsafe { _mm256_sub_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            F8(unsafe { _mm256_mul_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            F8(unsafe { _mm256_div_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn neg(self) -> Self {
            F8(unsafe { _mm256_xor_ps(_mm256_set1_ps(-0.0), self.0) })
        }
        #[inline(always)]
        fn min(self, o: Self) -> Self {
            F8(unsafe { _mm256_min_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn max(self, o: Self) -> Self {
            F8(unsafe { _mm256_max_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn gt(self, o: Self) -> F8 {
            F8(unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn lt(self, o: Self) -> F8 {
            F8(unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn ge(self, o: Self) -> F8 {
            F8(unsafe { _mm256_cmp_ps::<_CMP_GE_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn le(self, o: Self) -> F8 {
            F8(unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn bitmask(m: F8) -> u32 {
            unsafe { _mm256_movemask_ps(m.0) as u32 }
        }
    }
}
