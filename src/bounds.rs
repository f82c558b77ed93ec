//! Axis-aligned bounding boxes, shared by meshes and the native BVH.

use glam::Vec3;

/// An axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Bounds {
    /// The empty box (contains nothing; any union replaces it).
    pub const EMPTY: Bounds = Bounds { min: Vec3::INFINITY, max: Vec3::NEG_INFINITY };

    /// The box around `points`.
    pub fn of(points: &[Vec3]) -> Bounds {
        points.iter().fold(Bounds::EMPTY, |b, &p| b.grow(p))
    }

    /// This box grown to include `p`.
    pub fn grow(self, p: Vec3) -> Bounds {
        Bounds { min: self.min.min(p), max: self.max.max(p) }
    }

    /// The box around both.
    pub fn union(self, other: Bounds) -> Bounds {
        Bounds { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    /// The axis (0, 1, 2 for x, y, z) along which the box is widest, ties
    /// to the first: where the trees over lights and photons split.
    pub fn widest_axis(&self) -> usize {
        let extent = self.max - self.min;
        if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        }
    }

    /// Half the surface area (what the SAH compares); 0 for an empty box.
    pub fn half_area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_grow_and_measure() {
        assert_eq!(Bounds::EMPTY.half_area(), 0.0);
        let b = Bounds::of(&[Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0)]);
        assert_eq!(b.half_area(), 1.0 * 2.0 + 2.0 * 3.0 + 3.0 * 1.0);
        assert_eq!(b.union(Bounds::of(&[Vec3::splat(-1.0)])).min, Vec3::splat(-1.0));
    }
}
