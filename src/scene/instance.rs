//! Meshes declared once in a scene file (`"meshes"`) and placed by `instance` objects, each
//! through a transform (#64): a 4x4 matrix, row-major, or a translation, a rotation and a
//! scale. An instance is one object, its triangles the mesh's in the mesh's order, moved into
//! world space in f64: the flattened scene, which a two-level tree is to match.

use glam::{DAffine3, DMat3, DQuat, DVec3};
use serde::Deserialize;

use super::Triangle;

/// A transform as a scene file gives it.
#[derive(Deserialize, Debug)]
#[serde(untagged)]
pub(super) enum TransformFile {
    /// Four rows of four numbers, the last `[0, 0, 0, 1]`: a point `p` goes to `M [p, 1]`.
    Matrix([[f64; 4]; 4]),
    /// Scaled, then rotated, then translated.
    Parts(PartsFile),
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(super) struct PartsFile {
    #[serde(default)]
    translate: Option<[f64; 3]>,
    #[serde(default)]
    rotate: Option<RotateFile>,
    #[serde(default)]
    scale: Option<ScaleFile>,
}

/// A rotation: `degrees` counterclockwise about `axis` (seen from its tip), or a quaternion
/// `[w, x, y, z]` (normalised on load).
#[derive(Deserialize, Debug)]
#[serde(untagged)]
enum RotateFile {
    AxisAngle { axis: [f64; 3], degrees: f64 },
    Quaternion { quaternion: [f64; 4] },
}

/// One factor for every axis, or one an axis.
#[derive(Deserialize, Debug)]
#[serde(untagged)]
enum ScaleFile {
    Uniform(f64),
    Axes([f64; 3]),
}

/// What serde says of a transform that is neither form, and what is said instead.
pub(super) const SHAPES: [(&str, &str); 3] = [
    (
        "data did not match any variant of untagged enum TransformFile",
        "expected a 4x4 matrix (four rows of four numbers) or an object of \"translate\", \"rotate\" and \"scale\"",
    ),
    (
        "data did not match any variant of untagged enum RotateFile",
        "expected {\"axis\": [x, y, z], \"degrees\": a} or {\"quaternion\": [w, x, y, z]}",
    ),
    (
        "data did not match any variant of untagged enum ScaleFile",
        "expected a number or [sx, sy, sz]",
    ),
];

impl TransformFile {
    /// Every number given, with the field it is under (relative to the transform).
    pub(super) fn numbers(&self) -> Vec<(String, f64)> {
        match self {
            TransformFile::Matrix(rows) => (0..16)
                .map(|k| (format!("[{}][{}]", k / 4, k % 4), rows[k / 4][k % 4]))
                .collect(),
            TransformFile::Parts(p) => {
                let mut numbers = Vec::new();
                if let Some(t) = &p.translate {
                    named(&mut numbers, ".translate", t);
                }
                match &p.rotate {
                    Some(RotateFile::AxisAngle { axis, degrees }) => {
                        named(&mut numbers, ".rotate.axis", axis);
                        numbers.push((".rotate.degrees".into(), *degrees));
                    }
                    Some(RotateFile::Quaternion { quaternion }) => {
                        named(&mut numbers, ".rotate.quaternion", quaternion)
                    }
                    None => {}
                }
                match &p.scale {
                    Some(ScaleFile::Uniform(s)) => numbers.push((".scale".into(), *s)),
                    Some(ScaleFile::Axes(s)) => named(&mut numbers, ".scale", s),
                    None => {}
                }
                numbers
            }
        }
    }

    /// The affine map, or what is wrong with it (the field under the transform, and why):
    /// a matrix whose last row is not `[0, 0, 0, 1]`, a zero rotation axis or quaternion, a
    /// zero scale, a singular linear part. The numbers are finite ([`TransformFile::numbers`]
    /// checked first).
    pub(super) fn affine(&self) -> Result<DAffine3, (String, String)> {
        let m = match self {
            TransformFile::Matrix(rows) => {
                if rows[3] != [0.0, 0.0, 0.0, 1.0] {
                    return Err((
                        "[3]".into(),
                        "the last row must be [0, 0, 0, 1]: an affine transform".into(),
                    ));
                }
                let column = |c: usize| DVec3::new(rows[0][c], rows[1][c], rows[2][c]);
                DAffine3 {
                    matrix3: DMat3::from_cols(column(0), column(1), column(2)),
                    translation: column(3),
                }
            }
            TransformFile::Parts(p) => p.affine()?,
        };
        match singular(&m) {
            Some(why) => Err((String::new(), why)),
            None => Ok(m),
        }
    }
}

impl PartsFile {
    fn affine(&self) -> Result<DAffine3, (String, String)> {
        let rotation = match &self.rotate {
            None => DQuat::IDENTITY,
            Some(RotateFile::AxisAngle { axis, degrees }) => {
                let axis = DVec3::from_array(*axis);
                if axis.length() == 0.0 {
                    return Err((".rotate.axis".into(), "must be a non-zero vector".into()));
                }
                DQuat::from_axis_angle(axis.normalize(), degrees.to_radians())
            }
            Some(RotateFile::Quaternion {
                quaternion: [w, x, y, z],
            }) => {
                let q = DQuat::from_xyzw(*x, *y, *z, *w);
                if q.length() == 0.0 {
                    return Err((".rotate.quaternion".into(), "must be non-zero".into()));
                }
                q.normalize()
            }
        };
        let scale = match self.scale {
            None => DVec3::ONE,
            Some(ScaleFile::Uniform(s)) => DVec3::splat(s),
            Some(ScaleFile::Axes(s)) => DVec3::from_array(s),
        };
        if scale.to_array().contains(&0.0) {
            return Err((".scale".into(), "must not be 0 (a flat mesh)".into()));
        }
        let translation = DVec3::from_array(self.translate.unwrap_or_default());
        Ok(DAffine3::from_scale_rotation_translation(
            scale,
            rotation,
            translation,
        ))
    }
}

/// Why `m` cannot place a mesh, where its linear part is singular, or so near it that the
/// placed mesh would be flat to f64's precision (NaN and infinite entries are singular too).
pub(crate) fn singular(m: &DAffine3) -> Option<String> {
    let det = m.matrix3.determinant();
    let size = (m.matrix3.to_cols_array().iter()).fold(0.0f64, |a, x| a.max(x.abs()));
    let flat = det.is_nan() || det.abs() <= 1e-12 * size * size * size;
    flat.then(|| format!("is singular (determinant {det:e})"))
}

/// `xs` as the numbers of field `name`, `name[k]` each.
fn named(numbers: &mut Vec<(String, f64)>, name: &str, xs: &[f64]) {
    numbers.extend(
        xs.iter()
            .enumerate()
            .map(|(k, &x)| (format!("{name}[{k}]"), x)),
    );
}

/// `triangles` moved by `m` into world space. Where `m` mirrors (a negative determinant) each
/// triangle's last two corners swap, so that a normal, which follows the corners' order, keeps
/// to the side it was on: outward stays outward.
pub(crate) fn place(triangles: &[Triangle], m: &DAffine3) -> Vec<Triangle> {
    let mirrors = m.matrix3.determinant() < 0.0;
    (triangles.iter()).map(|t| placed(t, m, mirrors)).collect()
}

/// [`place`] into `placed_copy`, the memory of a copy placed before (resized to `triangles`).
pub(crate) fn place_into(placed_copy: &mut Vec<Triangle>, triangles: &[Triangle], m: &DAffine3) {
    let mirrors = m.matrix3.determinant() < 0.0;
    placed_copy.resize(triangles.len(), [DVec3::ZERO; 3]);
    for (out, t) in placed_copy.iter_mut().zip(triangles) {
        *out = placed(t, m, mirrors);
    }
}

/// Triangle `t` moved by `m`, its last two corners swapped where `m` mirrors.
fn placed(t: &Triangle, m: &DAffine3, mirrors: bool) -> Triangle {
    let [a, b, c] = t.map(|p| m.transform_point3(p));
    if mirrors { [a, c, b] } else { [a, b, c] }
}

/// The box `(lo, hi)` moved by `m`: the box around its moved corners, which holds whatever
/// the box held, moved.
pub(crate) fn moved_box((lo, hi): (DVec3, DVec3), m: &DAffine3) -> (DVec3, DVec3) {
    (0..8)
        .map(|k| {
            let pick = |bit: usize, l: f64, h: f64| if k & bit == 0 { l } else { h };
            m.transform_point3(DVec3::new(
                pick(1, lo.x, hi.x),
                pick(2, lo.y, hi.y),
                pick(4, lo.z, hi.z),
            ))
        })
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), c| {
            (l.min(c), h.max(c))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(json: &str) -> TransformFile {
        serde_json::from_str(json).unwrap()
    }

    /// Translate, rotate and scale compose as scale, then rotate, then translate, and the same
    /// map written as a matrix is the same map.
    #[test]
    fn parts_and_matrix_agree() {
        let parts = parse(
            r#"{"translate": [1, 2, 3], "rotate": {"axis": [0, 0, 1], "degrees": 90}, "scale": [2, 3, 4]}"#,
        );
        let m = parts.affine().unwrap();
        let p = m.transform_point3(DVec3::new(1.0, 1.0, 1.0));
        // (1,1,1) scaled (2,3,4), turned 90 degrees about z: (-3, 2, 4), then moved.
        assert!((p - DVec3::new(-2.0, 4.0, 7.0)).length() < 1e-12, "{p}");
        let matrix = parse("[[0, -3, 0, 1], [2, 0, 0, 2], [0, 0, 4, 3], [0, 0, 0, 1]]");
        let q = matrix
            .affine()
            .unwrap()
            .transform_point3(DVec3::new(1.0, 1.0, 1.0));
        assert!((p - q).length() < 1e-12, "{q}");
        let quaternion = parse(
            r#"{"translate": [1, 2, 3], "rotate": {"quaternion": [0.7071067811865476, 0, 0, 0.7071067811865476]}, "scale": [2, 3, 4]}"#,
        );
        let r = quaternion
            .affine()
            .unwrap()
            .transform_point3(DVec3::new(1.0, 1.0, 1.0));
        assert!((p - r).length() < 1e-12, "{r}");
    }

    #[test]
    fn a_mirror_swaps_corners_and_keeps_the_normal_outward() {
        let t: Triangle = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let normal = |t: &Triangle| (t[1] - t[0]).cross(t[2] - t[0]);
        let mirror = parse(r#"{"scale": [1, 1, -1]}"#).affine().unwrap();
        let placed = place(&[t], &mirror)[0];
        // A mirror through z = 0 leaves a triangle in that plane where it is, facing +z.
        assert_eq!(placed, [DVec3::ZERO, DVec3::Y, DVec3::X]);
        assert_eq!(normal(&placed).z.signum(), -normal(&t).z.signum());
        let flip = parse(r#"{"scale": [1, -1, 1]}"#).affine().unwrap();
        let placed = place(&[[DVec3::ZERO, DVec3::X, DVec3::Z]], &flip)[0];
        // The triangle in y = 0 faces -y; mirrored through y = 0 it must face +y.
        assert!(normal(&placed).y > 0.0, "{placed:?}");
    }

    #[test]
    fn bad_transforms_say_where() {
        let cases = [
            (
                "[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]",
                "[3]",
            ),
            (
                "[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]",
                "",
            ),
            (r#"{"scale": [1, 0, 1]}"#, ".scale"),
            (
                r#"{"rotate": {"axis": [0, 0, 0], "degrees": 5}}"#,
                ".rotate.axis",
            ),
            (
                r#"{"rotate": {"quaternion": [0, 0, 0, 0]}}"#,
                ".rotate.quaternion",
            ),
            (r#"{"scale": [1e-9, 1e-9, 1]}"#, ""),
        ];
        for (json, field) in cases {
            let (at, _) = parse(json).affine().unwrap_err();
            assert_eq!(at, field, "{json}");
        }
    }
}
