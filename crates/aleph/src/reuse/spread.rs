//! Held fireflies' light, spread over their surface rather than lost ([`super`], "Held
//! fireflies").
//!
//! A reused frame dropped at a pixel as a held firefly takes its excess over the pixel's other
//! samples with it: on the moving-sphere box (128², frames 12–19, 4 fresh spp, 8 seeds) the
//! ceiling, lit by bounce light and by caustic paths through the spheres, came out 24 % darker
//! than the reference, the floor 5 %. That light is not wrong, only too concentrated to hold
//! still at one pixel for K frames. So each pixel's excess (the mean with the dropped frames
//! less the mean without them) is shared out evenly over the pixels of the same surface in its
//! (2 [`SPREAD_RADIUS`] + 1)² neighbourhood: the same material, normals within
//! [`NORMAL_TOLERANCE_DEG`](super::NORMAL_TOLERANCE_DEG). The image keeps its light (the sum
//! over pixels is unchanged) and a firefly becomes a patch of up to 729 pixels at 1/729 of its
//! excess. Bounce light on a surface varies slowly, so this moves it by little; the price is
//! that the spread light of a small bright feature the fresh samples did not see is blurred
//! over the patch.

use crate::gbuffer::GBuffer;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Half-width of the square a pixel's dropped excess is spread over, pixels: 27 × 27, the
/// largest neighbourhood of the test ([`super::TEST_RADII`]). Measured on the moving-sphere
/// box (128², frames 12–19, 1–16 fresh spp): the smallest of 3 × 3, 9 × 9 and 27 × 27 whose
/// share stayed under a quarter of the pixel's level scored 0.25–0.76 video JOD below this at
/// every budget, and below dropping the light at 1–8 spp: a still patch is seen.
pub const SPREAD_RADIUS: usize = 13;

/// What a pixel sees at its centre, to tell which neighbours show the same surface.
#[derive(Clone, Debug, Default)]
pub(super) struct Surfaces {
    width: usize,
    height: usize,
    /// Material index per pixel (`u32::MAX` for the background).
    material: Vec<u32>,
    /// World-space normal per pixel.
    normal: Vec<Vec3>,
    /// Least cosine between two normals of one surface.
    cos_normal: f32,
}

impl Surfaces {
    /// The surfaces of G-buffer `g`.
    pub(super) fn of(g: &GBuffer) -> Surfaces {
        Surfaces {
            width: g.width,
            height: g.height,
            material: g.material.clone(),
            normal: g.normal.chunks_exact(3).map(Vec3::from_slice).collect(),
            cos_normal: super::NORMAL_TOLERANCE_DEG.to_radians().cos(),
        }
    }

    /// A `w × h` image of one flat surface (for tests).
    #[cfg(test)]
    pub(super) fn wall(w: usize, h: usize) -> Surfaces {
        Surfaces {
            width: w,
            height: h,
            material: vec![0; w * h],
            normal: vec![Vec3::Z; w * h],
            cos_normal: 0.9,
        }
    }

    /// Whether pixels `i` and `j` show the same surface (a pixel always shows its own; the
    /// background none other).
    fn same(&self, i: usize, j: usize) -> bool {
        i == j
            || (self.material[i] == self.material[j]
                && self.material[i] != u32::MAX
                && self.normal[i].dot(self.normal[j]) >= self.cos_normal)
    }

    /// The pixels of `i`'s neighbourhood that show its surface.
    fn patch(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        let w = self.width;
        let xs = span(i % w, w);
        span(i / w, self.height)
            .flat_map(move |yy| xs.clone().map(move |xx| yy * w + xx))
            .filter(move |&j| self.same(i, j))
    }
}

/// The columns (or rows) within [`SPREAD_RADIUS`] of `c` in an image `n` wide (or high).
fn span(c: usize, n: usize) -> std::ops::Range<usize> {
    c.saturating_sub(SPREAD_RADIUS)..(c + SPREAD_RADIUS + 1).min(n)
}

/// Spreads each pixel's `excess` (radiance, row-major, one per pixel of `s`) evenly over the
/// pixels of its patch ([`Surfaces::patch`]); returns the radiance each pixel receives. The
/// sum over the image is the excess's sum (up to rounding), and every pixel's share is summed
/// in one fixed order, so the result does not depend on the thread count.
///
/// # Panics
/// If `excess` does not hold one value per pixel of `s`.
pub(super) fn spread(excess: &[DVec3], s: &Surfaces) -> Vec<DVec3> {
    let (w, h) = (s.width, s.height);
    assert_eq!(excess.len(), w * h, "one excess per pixel");
    // Per row, the pixels that have an excess (in order of x) and the share each pixel of
    // their patch takes.
    let rows: Vec<Vec<(usize, DVec3)>> = (0..h)
        .into_par_iter()
        .map(|y| {
            (y * w..(y + 1) * w)
                .filter(|&i| excess[i] != DVec3::ZERO)
                .map(|i| (i, excess[i] / s.patch(i).count() as f64))
                .collect()
        })
        .collect();
    if rows.iter().all(Vec::is_empty) {
        return vec![DVec3::ZERO; w * h];
    }
    // Each row of the result gathers from the excess pixels of the rows within the radius, in
    // the order of the rows and then of x, each adding its share along its patch's span of the
    // row: the same sums in the same order as visiting every pixel's neighbourhood, without a
    // search per pixel and row where excess is sparse.
    let mut out = vec![DVec3::ZERO; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row_out)| {
        for &(i, share) in span(y, h).flat_map(|yy| &rows[yy]) {
            for xx in span(i % w, w) {
                if s.same(i, y * w + xx) {
                    row_out[xx] += share;
                }
            }
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w × h` image whose left half is material 0 facing +z and right half material 1.
    fn two_walls(w: usize, h: usize) -> Surfaces {
        Surfaces {
            width: w,
            height: h,
            material: (0..w * h).map(|i| u32::from(i % w >= w / 2)).collect(),
            normal: vec![Vec3::Z; w * h],
            cos_normal: 0.9,
        }
    }

    #[test]
    fn spread_light_stays_on_its_surface_and_sums_to_the_excess() {
        let (w, h) = (64, 40);
        let s = two_walls(w, h);
        let mut excess = vec![DVec3::ZERO; w * h];
        // A firefly beside the seam, one in a corner, one far from any edge.
        excess[10 * w + 30] = DVec3::new(3.0, 2.0, 1.0);
        excess[0] = DVec3::splat(5.0);
        excess[20 * w + 50] = DVec3::splat(7.0);
        let got = spread(&excess, &s);
        let total = |v: &[DVec3], right: bool| -> DVec3 {
            v.iter()
                .enumerate()
                .filter(|(i, _)| (i % w >= w / 2) == right)
                .map(|(_, e)| *e)
                .sum()
        };
        for right in [false, true] {
            let (a, b) = (total(&got, right), total(&excess, right));
            assert!((a - b).abs().max_element() < 1e-12, "{a} against {b}");
        }
        // The far firefly covers its whole 27 × 27 patch evenly.
        let one = 7.0 / 729.0;
        assert!((got[(20 - 13) * w + 50 - 13].x - one).abs() < 1e-12);
        assert!((got[(20 + 13) * w + 50 + 13].x - one).abs() < 1e-12);
        assert_eq!(got[(20 + 14) * w + 50].x, 0.0);
        // The corner's reaches 14 × 14 pixels.
        assert!((got[13 * w + 13].y - 5.0 / 196.0).abs() < 1e-12);
    }

    #[test]
    fn nothing_to_spread_gives_nothing() {
        let s = two_walls(8, 8);
        assert!(
            spread(&[DVec3::ZERO; 64], &s)
                .iter()
                .all(|e| *e == DVec3::ZERO)
        );
    }
}
