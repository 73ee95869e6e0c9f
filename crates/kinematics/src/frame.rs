//! Rigid transforms: [`Frame`], and the one Euler-angle convention of the workspace
//! ([`Frame::from_base_pose`]: the robot's base and the tracker's base-frame residual).

use nalgebra::{Matrix3, Vector3};

/// A rigid transform `x ↦ rot · x + pos_mm` (rotation matrix and translation in mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Rotation (orthonormal, det +1).
    pub rot: Matrix3<f64>,
    /// Translation, mm.
    pub pos_mm: Vector3<f64>,
}

impl Frame {
    /// The identity transform.
    pub fn identity() -> Self {
        Frame {
            rot: Matrix3::identity(),
            pos_mm: Vector3::zeros(),
        }
    }

    /// `self · other`.
    #[inline]
    pub fn compose(&self, other: &Frame) -> Frame {
        Frame {
            rot: self.rot * other.rot,
            pos_mm: self.rot * other.pos_mm + self.pos_mm,
        }
    }

    /// Maps a point given in this frame into the parent frame.
    #[inline]
    pub fn transform_point(&self, p_mm: &Vector3<f64>) -> Vector3<f64> {
        self.rot * p_mm + self.pos_mm
    }

    /// `Trans(d) · Rz(rz) · Ry(ry) · Rx(rx)`, rotations in radians, translation in mm: the
    /// base convention of `docs/model.md` §2 (the robot's base pose and the tracker's
    /// base-frame residual, so that the six base parameters can absorb the latter exactly).
    /// The one Euler → frame conversion of the workspace.
    pub fn from_base_pose(r_rad: [f64; 3], d_mm: [f64; 3]) -> Frame {
        Frame {
            rot: crate::rotation::from_rpy(r_rad),
            pos_mm: Vector3::from(d_mm),
        }
    }

    /// The inverse transform.
    pub fn inverse(&self) -> Frame {
        let rt = self.rot.transpose();
        Frame {
            rot: rt,
            pos_mm: -(rt * self.pos_mm),
        }
    }
}
