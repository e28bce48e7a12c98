//! `raycast._raycast`: the native half of the Python package. The Python half
//! (python/raycast/__init__.py) checks and converts arguments (NumPy arrays of any float dtype
//! and layout become one contiguous float64 array; rays stay float32 where they are) and shapes
//! the results; this half casts, with the GIL released, and hands the result vectors to NumPy
//! without copying them.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, OnceLock};

use numpy::{PyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use raycast::Camera;
use raycast::RayList;
use raycast::{
    Accel, Algorithm, AnyHits, AnyImages, Closest, Cpu, Device, Encoding, Format, Geometry, Gpu,
    Hits, Intersections, Precision, Ray, RenderOptions, ShadeHook, Sign, Viewer,
};
use raycast::{DAffine3, DVec3};
use raycast_datasets::{RenderFiles, RenderViews, ViewRenderer, Views};

/// The process's GPU, opened on first use (lavapipe where there is no other).
fn gpu() -> PyResult<&'static Gpu> {
    static GPU: OnceLock<Result<Gpu, String>> = OnceLock::new();
    GPU.get_or_init(|| Gpu::new().map_err(|e| e.to_string()))
        .as_ref()
        .map_err(|e| PyRuntimeError::new_err(format!("no GPU: {e}")))
}

/// `raycast::Error` as the Python exception for it: bad arguments raise ValueError, the rest
/// RuntimeError; the arguments it names spelled as this package's.
fn to_py(e: raycast::Error) -> PyErr {
    let e = e.spelled(&|name| {
        let spelled = match name {
            "Gpu" => "device=\"gpu\"",
            "ShadeHook::raytrace" => "lit=True",
            "shade" => "shader",
            "samples" => "nsamples",
            _ => return None,
        };
        Some(spelled.to_string())
    });
    match e {
        raycast::Error::Argument { .. }
        | raycast::Error::SceneSyntax { .. }
        | raycast::Error::SceneValue { .. }
        | raycast::Error::Mesh { .. } => PyValueError::new_err(e.to_string()),
        raycast::Error::Io { .. } => pyo3::exceptions::PyOSError::new_err(e.to_string()),
        raycast::Error::Memory { .. } => pyo3::exceptions::PyMemoryError::new_err(e.to_string()),
        _ => PyRuntimeError::new_err(e.to_string()),
    }
}

/// The affine maps of `rows` (argument `what`), each a 4x4 matrix row-major in one row of 16,
/// its last row `[0, 0, 0, 1]`.
fn affines(rows: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<DAffine3>> {
    let flat = rows
        .as_slice()
        .map_err(|_| PyValueError::new_err(format!("{what}: expected a contiguous array")))?;
    (flat.chunks_exact(16).enumerate())
        .map(|(k, m)| {
            if m[12..] != [0.0, 0.0, 0.0, 1.0] {
                let name = if what == "transform" {
                    what.to_string()
                } else {
                    format!("{what}[{k}]")
                };
                return Err(PyValueError::new_err(format!(
                    "{name}: the last row must be [0, 0, 0, 1]: an affine transform"
                )));
            }
            let column = |c: usize| DVec3::new(m[c], m[4 + c], m[8 + c]);
            Ok(DAffine3::from_cols(
                column(0),
                column(1),
                column(2),
                column(3),
            ))
        })
        .collect()
}

/// Where a call runs: `device` is "gpu" or "cpu", `precision` "f32", "f64" or "adaptive".
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
struct On {
    gpu: bool,
    precision: Precision,
}

fn on(device: &str, precision: &str) -> PyResult<On> {
    let gpu = on_gpu(device)?;
    let precision = precision.parse().map_err(PyValueError::new_err)?;
    Ok(On { gpu, precision })
}

/// Whether `device` ("gpu" or "cpu") is the GPU.
fn on_gpu(device: &str) -> PyResult<bool> {
    match device {
        "gpu" => Ok(true),
        "cpu" => Ok(false),
        other => Err(PyValueError::new_err(format!(
            "unknown device `{other}` (expected gpu or cpu)"
        ))),
    }
}

/// Rays as the Python half passes them: (n, 6) float32 (as Open3D's callers hold them) or
/// float64, C-contiguous.
#[derive(FromPyObject)]
enum RayArray<'py> {
    F32(PyReadonlyArray2<'py, f32>),
    F64(PyReadonlyArray2<'py, f64>),
}

/// Rows of `origin, direction` as rays, without copying; an image's in rows of `width`.
fn ray_list<'a>(rays: &'a RayArray<'_>, width: Option<usize>) -> PyResult<RayList<'a>> {
    let contiguous = || PyValueError::new_err("rays: expected a contiguous array");
    let rows = || PyValueError::new_err("rays: expected rows of 6 numbers");
    let rows: RayList<'a> = match rays {
        RayArray::F32(a) => {
            let flat = a.as_slice().map_err(|_| contiguous())?;
            let rows: &[[f32; 6]] = bytemuck::try_cast_slice(flat).map_err(|_| rows())?;
            rows.into()
        }
        RayArray::F64(a) => {
            let flat = a.as_slice().map_err(|_| contiguous())?;
            let rays: &[Ray] = bytemuck::try_cast_slice(flat).map_err(|_| rows())?;
            rays.into()
        }
    };
    Ok(match width {
        Some(w) => RayList::image(rows, w),
        None => rows,
    })
}

/// Which rays Open3D answers as misses, whatever the scene: those with a NaN or infinite
/// coordinate or a zero direction (the library refuses them). None where there are none, the
/// common case, found in one pass that allocates nothing.
#[pyfunction]
fn invalid_rays<'py>(
    py: Python<'py>,
    rays: RayArray<'_>,
) -> PyResult<Option<Bound<'py, PyArray1<bool>>>> {
    let mask = match &rays {
        RayArray::F32(a) => invalid_rows(py, rows_of::<f32, 6>(a, "rays")?, invalid_ray),
        RayArray::F64(a) => invalid_rows(py, rows_of::<f64, 6>(a, "rays")?, invalid_ray),
    };
    Ok(mask.map(|m| PyArray1::from_vec(py, m)))
}

/// Which query points Open3D answers without a surface (nan or inf distances, occupancy 0):
/// those with a NaN or infinite coordinate. None where there are none.
#[pyfunction]
fn invalid_points<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'_, f64>,
) -> PyResult<Option<Bound<'py, PyArray1<bool>>>> {
    let rows = rows_of::<f64, 3>(&points, "query_points")?;
    let mask = invalid_rows(py, rows, |p| !finite(p));
    Ok(mask.map(|m| PyArray1::from_vec(py, m)))
}

/// Whether the ray `row` (origin, direction) is one Open3D answers as a miss.
fn invalid_ray<T: Into<f64> + Copy>(row: &[T; 6]) -> bool {
    let x = row.map(Into::into);
    !finite(&x) | ((x[3] == 0.0) & (x[4] == 0.0) & (x[5] == 0.0))
}

/// Whether every number is finite, without branches, so that a scan of many vectorises.
fn finite(x: &[f64]) -> bool {
    x.iter().fold(true, |ok, x| ok & x.is_finite())
}

/// A C-contiguous (n, N) array as its rows, without copying.
fn rows_of<'a, T: numpy::Element + bytemuck::Pod, const N: usize>(
    array: &'a PyReadonlyArray2<'_, T>,
    name: &str,
) -> PyResult<&'a [[T; N]]>
where
    [T; N]: bytemuck::Pod,
{
    let flat = (array.as_slice())
        .map_err(|_| PyValueError::new_err(format!("{name}: expected a contiguous array")))?;
    bytemuck::try_cast_slice(flat)
        .map_err(|_| PyValueError::new_err(format!("{name}: expected rows of {N} numbers")))
}

/// Whether each row is `invalid`, or None where none is; with the GIL released.
fn invalid_rows<T: Sync, const N: usize>(
    py: Python<'_>,
    rows: &[[T; N]],
    invalid: impl Fn(&[T; N]) -> bool + Sync,
) -> Option<Vec<bool>> {
    py.detach(|| {
        // Blocks of rows without branches inside, so that they vectorise.
        let any_in = |block: &[[T; N]]| block.iter().fold(false, |any, row| any | invalid(row));
        let any = rows.chunks(1024).any(any_in);
        any.then(|| rows.iter().map(&invalid).collect())
    })
}

/// A vector of fixed-size arrays as the flat vector of their elements, without copying.
fn flat<T: bytemuck::Pod, const N: usize>(v: Vec<[T; N]>) -> Vec<T>
where
    [T; N]: bytemuck::Pod,
{
    bytemuck::allocation::try_cast_vec(v).unwrap_or_else(|(_, v)| v.concat())
}

/// The hits as a dict of flat arrays (the Python half reshapes them).
fn hits_dict<'py, T: numpy::Element + bytemuck::Pod>(
    py: Python<'py>,
    h: Hits<T>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("t_hit", PyArray1::from_vec(py, h.t))?;
    // A miss's id -1 is 4294967295 as uint32: Open3D's INVALID_ID.
    let ids: Vec<u32> = bytemuck::allocation::cast_vec(h.id);
    d.set_item("geometry_ids", PyArray1::from_vec(py, ids))?;
    d.set_item("primitive_ids", PyArray1::from_vec(py, h.primitive))?;
    d.set_item("primitive_uvs", PyArray1::from_vec(py, flat(h.uv)))?;
    d.set_item("primitive_normals", PyArray1::from_vec(py, flat(h.normal)))?;
    Ok(d)
}

/// Query points as the Python half passes them: (n, 3) float64, C-contiguous.
fn point_list<'a>(points: &'a PyReadonlyArray2<'_, f64>) -> PyResult<&'a [DVec3]> {
    rows_of::<f64, 3>(points, "query_points").map(bytemuck::cast_slice)
}

/// Vectors as rows of three numbers (the same bytes).
fn vectors(v: Vec<DVec3>) -> Vec<[f64; 3]> {
    bytemuck::allocation::cast_vec(v)
}

/// A vector of f64 as NumPy float32 (f32 and adaptive queries, as Open3D's) or float64.
fn real_array<'py>(py: Python<'py>, v: Vec<f64>, f64_out: bool) -> Bound<'py, PyAny> {
    match f64_out {
        true => PyArray1::from_vec(py, v).into_any(),
        false => PyArray1::from_vec(py, v.into_iter().map(|x| x as f32).collect()).into_any(),
    }
}

/// Object ids as Open3D's uint32 (a miss's -1 is its INVALID_ID).
fn id_array(py: Python<'_>, id: Vec<i32>) -> Bound<'_, PyArray1<u32>> {
    PyArray1::from_vec(py, bytemuck::allocation::cast_vec(id))
}

fn closest_dict(py: Python<'_>, c: Closest, f64_out: bool) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("points", real_array(py, flat(vectors(c.point)), f64_out))?;
    d.set_item("distance", real_array(py, c.distance, f64_out))?;
    d.set_item("geometry_ids", id_array(py, c.id))?;
    d.set_item("primitive_ids", PyArray1::from_vec(py, c.primitive))?;
    d.set_item("primitive_uvs", real_array(py, flat(c.uv), f64_out))?;
    d.set_item(
        "primitive_normals",
        real_array(py, flat(vectors(c.normal)), f64_out),
    )?;
    Ok(d)
}

fn intersections_dict(
    py: Python<'_>,
    i: Intersections,
    f64_out: bool,
) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    let splits: Vec<u32> = i.ray_splits.iter().map(|&s| s as u32).collect();
    d.set_item("ray_splits", PyArray1::from_vec(py, splits))?;
    d.set_item("ray_ids", PyArray1::from_vec(py, i.ray_id))?;
    d.set_item("t_hit", real_array(py, i.t, f64_out))?;
    d.set_item("geometry_ids", id_array(py, i.id))?;
    d.set_item("primitive_ids", PyArray1::from_vec(py, i.primitive))?;
    d.set_item("primitive_uvs", real_array(py, flat(i.uv), f64_out))?;
    Ok(d)
}

/// The objects rays are cast at (wrapped by `raycast.RaycastingScene`), committed to a device
/// and precision on the first cast there, and again after objects are added.
#[pyclass(name = "Scene", module = "raycast._raycast")]
struct Scene {
    geometry: Geometry,
    /// The scene file it was loaded from, whose camera `render` renders; its BVH's shape is
    /// built once for every view `render` is given.
    scene: Option<Arc<Mutex<Viewer>>>,
    accels: Mutex<HashMap<On, Arc<Accel<'static>>>>,
    /// The scene file's instances moved by `set_transforms`, as its viewer was last posed.
    posed: Vec<(usize, DAffine3)>,
}

impl Scene {
    fn with(geometry: Geometry, scene: Option<raycast::Scene>) -> Self {
        Scene {
            geometry,
            scene: scene.map(|s| Arc::new(Mutex::new(Viewer::from(s)))),
            accels: Mutex::default(),
            posed: Vec::new(),
        }
    }

    /// The scene file's viewer; `call` names the method refused without one. Lock it only
    /// with the GIL released: a thread rendering it needs the GIL back to return.
    fn file(&self, call: &str) -> PyResult<&Arc<Mutex<Viewer>>> {
        self.scene.as_ref().ok_or_else(|| {
            PyValueError::new_err(format!(
                "{call}: the scene has no camera (load a scene file with raycast.load)"
            ))
        })
    }

    /// The geometry committed for `on`, committed now if it is not yet.
    fn accel(&self, on: On) -> PyResult<Arc<Accel<'static>>> {
        if let Some(accel) = self.accels.lock().expect("accels lock").get(&on) {
            return Ok(accel.clone());
        }
        let accel = Arc::new(
            match on.gpu {
                true => gpu()?.commit(&self.geometry, on.precision),
                false => Cpu.commit(&self.geometry, on.precision),
            }
            .map_err(to_py)?,
        );
        self.accels
            .lock()
            .expect("accels lock")
            .insert(on, accel.clone());
        Ok(accel)
    }

    fn added(&mut self, id: raycast::Result<u32>) -> PyResult<u32> {
        self.accels.get_mut().expect("accels lock").clear();
        id.map_err(to_py)
    }
}

#[pymethods]
impl Scene {
    #[new]
    fn new() -> Self {
        Scene::with(Geometry::new(), None)
    }

    /// A scene file's objects (and its camera, for `render`). What the file holds that is
    /// likely a mistake (a mesh declared and never placed) comes as a `UserWarning`.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let scene = raycast::Scene::load(&path).map_err(to_py)?;
        let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
        for warning in &scene.warnings {
            let message = std::ffi::CString::new(warning.as_str())
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
            PyErr::warn(py, &category, &message, 1)?;
        }
        Ok(Scene::with(Geometry::from_scene(&scene), Some(scene)))
    }

    /// The views of this scene file's scene, named: the cameras of `cameras` (a views file's
    /// JSON text: a list of cameras in the scene format, each with a `name`), or an orbit of
    /// `orbit` views (at `orbit_radius` and `orbit_elevation` where given), as `raycast render
    /// --views` or `--orbit` renders them. Errors name a camera as `cameras[k]`.
    #[pyo3(signature = (cameras=None, orbit=None, orbit_radius=None, orbit_elevation=None))]
    fn views(
        &self,
        py: Python<'_>,
        cameras: Option<String>,
        orbit: Option<u32>,
        orbit_radius: Option<f64>,
        orbit_elevation: Option<f64>,
    ) -> PyResult<Vec<(String, ViewCamera)>> {
        let viewer = self.file("render_views")?;
        let views = match (cameras, orbit) {
            (Some(text), None) => Views::Json(text),
            (None, Some(views)) => Views::Orbit(raycast::Orbit {
                views,
                radius: orbit_radius,
                elevation: orbit_elevation,
                ..raycast::Orbit::default()
            }),
            _ => return Err(PyValueError::new_err("views: give cameras or orbit")),
        };
        let named = py
            .detach(|| views.cameras(viewer.lock().expect("the scene's lock").as_ref()))
            .map_err(cameras_error)?;
        Ok(named
            .into_iter()
            .map(|(name, camera)| (name, ViewCamera { camera }))
            .collect())
    }

    fn add_mesh(
        &mut self,
        vertices: PyReadonlyArray2<'_, f64>,
        triangles: PyReadonlyArray2<'_, u32>,
    ) -> PyResult<u32> {
        let v = vertices
            .as_slice()
            .map_err(|_| PyValueError::new_err("vertices: expected a contiguous array"))?;
        let t = triangles
            .as_slice()
            .map_err(|_| PyValueError::new_err("triangles: expected a contiguous array"))?;
        let v: Vec<DVec3> = v
            .chunks_exact(3)
            .map(|c| DVec3::new(c[0], c[1], c[2]))
            .collect();
        let t: Vec<[u32; 3]> = t.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let id = self.geometry.add_mesh(&v, &t);
        self.added(id)
    }

    /// Another copy of mesh `mesh` placed by `transform` (4x4, row-major, `[1, 16]`).
    fn add_instance(&mut self, mesh: u32, transform: PyReadonlyArray2<'_, f64>) -> PyResult<u32> {
        let m = affines(&transform, "transform")?[0];
        let id = self.geometry.add_instance(mesh, m);
        self.added(id)
    }

    /// Moves instances `ids` to `transforms` (`[n, 16]`, each 4x4 row-major). The scene
    /// file's instances move in its renders too: the viewer is posed first, which refuses an
    /// id the file does not place, then the geometry, which checks the transforms (and on
    /// refusing them, the viewer goes back to its pose).
    fn set_transforms(
        &mut self,
        py: Python<'_>,
        ids: Vec<u32>,
        transforms: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<()> {
        let ms = affines(&transforms, "transforms")?;
        let (before, mut posed) = (self.posed.clone(), self.posed.clone());
        if let Some(viewer) = &self.scene {
            let objects = py.detach(|| {
                viewer
                    .lock()
                    .expect("the scene's lock")
                    .as_ref()
                    .objects
                    .len()
            });
            for (&id, &m) in ids
                .iter()
                .zip(&ms)
                .filter(|(id, _)| (**id as usize) < objects)
            {
                posed.retain(|(o, _)| *o != id as usize);
                posed.push((id as usize, m));
            }
            let pose = |p: &[(usize, DAffine3)]| {
                py.detach(|| viewer.lock().expect("the scene's lock").pose(p))
            };
            pose(&posed).map_err(to_py)?;
            if let Err(e) = self.geometry.set_transforms(&ids, &ms) {
                pose(&before).map_err(to_py)?;
                return Err(to_py(e));
            }
        } else {
            self.geometry.set_transforms(&ids, &ms).map_err(to_py)?;
        }
        self.posed = posed;
        self.accels.get_mut().expect("accels lock").clear();
        Ok(())
    }

    fn add_sphere(&mut self, center: [f64; 3], radius: f64) -> PyResult<u32> {
        let id = self.geometry.add_sphere(center, radius);
        self.added(id)
    }

    fn add_plane(&mut self, point: [f64; 3], normal: [f64; 3]) -> PyResult<u32> {
        let id = self.geometry.add_plane(point, normal);
        self.added(id)
    }

    fn intersect<'py>(
        &self,
        py: Python<'py>,
        rays: RayArray<'_>,
        width: Option<usize>,
        precision: &str,
        device: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        let accel = self.accel(on(device, precision)?)?;
        let rays = ray_list(&rays, width)?;
        let hits = py.detach(|| accel.intersect(rays)).map_err(to_py)?;
        match hits {
            AnyHits::F32(h) => hits_dict(py, h),
            AnyHits::F64(h) => hits_dict(py, h),
        }
    }

    fn occluded<'py>(
        &self,
        py: Python<'py>,
        rays: RayArray<'_>,
        width: Option<usize>,
        t_range: (f64, f64),
        precision: &str,
        device: &str,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let (t_near, t_far) = t_range;
        let accel = self.accel(on(device, precision)?)?;
        let rays = ray_list(&rays, width)?;
        let hit = py
            .detach(|| accel.occluded(rays, t_near, t_far))
            .map_err(to_py)?;
        Ok(PyArray1::from_vec(py, hit))
    }

    fn count<'py>(
        &self,
        py: Python<'py>,
        rays: RayArray<'_>,
        precision: &str,
        device: &str,
    ) -> PyResult<Bound<'py, PyArray1<u32>>> {
        let accel = self.accel(on(device, precision)?)?;
        let rays = ray_list(&rays, None)?;
        let counts = py.detach(|| accel.count(rays)).map_err(to_py)?;
        Ok(PyArray1::from_vec(py, counts))
    }

    /// The closest point on the geometry to each query point, its distance, object, primitive,
    /// barycentrics and normal, as flat arrays.
    fn closest<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'_, f64>,
        precision: &str,
        device: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        let on = on(device, precision)?;
        let accel = self.accel(on)?;
        let points = point_list(&points)?;
        let c = py.detach(|| accel.closest(points)).map_err(to_py)?;
        closest_dict(py, c, on.precision == Precision::F64)
    }

    /// The generalized winding number at each query point (f64, on the CPU).
    fn winding_numbers<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'_, f64>,
        precision: &str,
        device: &str,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let accel = self.accel(on(device, precision)?)?;
        let points = point_list(&points)?;
        let w = py.detach(|| accel.winding_numbers(points)).map_err(to_py)?;
        Ok(PyArray1::from_vec(py, w))
    }

    /// Whether each query point is inside, by ray parity over `nsamples` rays or by winding
    /// number (`sign`).
    fn inside<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'_, f64>,
        sign: &str,
        nsamples: u32,
        precision: &str,
        device: &str,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let sign = match sign {
            "parity" => Sign::Parity { samples: nsamples },
            "winding" => Sign::Winding,
            other => {
                return Err(PyValueError::new_err(format!(
                    "sign: expected parity or winding, got {other:?}"
                )));
            }
        };
        let accel = self.accel(on(device, precision)?)?;
        let points = point_list(&points)?;
        let inside = py.detach(|| accel.inside(points, sign)).map_err(to_py)?;
        Ok(PyArray1::from_vec(py, inside))
    }

    /// Every hit of each ray, ordered by t, as Open3D's `list_intersections` gives them.
    fn every_hit<'py>(
        &self,
        py: Python<'py>,
        rays: RayArray<'_>,
        precision: &str,
        device: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        let on = on(device, precision)?;
        let accel = self.accel(on)?;
        let rays = ray_list(&rays, None)?;
        let hits = py.detach(|| accel.every_hit(rays)).map_err(to_py)?;
        intersections_dict(py, hits, on.precision == Precision::F64)
    }

    /// Renders the scene file's camera (or `camera`, from `camera` or `orbit`), at `size`
    /// where given (`--size`): id, distance and normal images as flat arrays and the image
    /// size; with `lit` (the course's ray tracer) or a shade hook file `shader`, also the
    /// colours and the rays the hook cast. `precision` `None`: the render's default
    /// (`Precision::default_for`), as the command line's.
    #[pyo3(signature = (precision, device, lit=false, shader=None, camera=None, size=None))]
    #[allow(clippy::too_many_arguments)]
    fn render<'py>(
        &self,
        py: Python<'py>,
        precision: Option<&str>,
        device: &str,
        lit: bool,
        shader: Option<PathBuf>,
        camera: Option<PyRef<'_, ViewCamera>>,
        size: Option<[u32; 2]>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let viewer = self.file("render")?;
        let (gpu, options) = render_options(precision, device, lit, shader)?;
        let camera = camera.map(|c| c.camera.clone());
        let rendered = py
            .detach(|| render_view(viewer, camera, size, gpu, &options))
            .map_err(to_py)?;
        images_dict(py, rendered)
    }

    /// [`Scene::render`] of each of `cameras` in turn, as an iterator of its dicts: a thread
    /// renders the next view while Python takes the last, so that one view waits at most.
    /// The hook is read once for every view.
    #[pyo3(signature = (precision, device, cameras, lit=false, shader=None))]
    fn render_each(
        &self,
        precision: Option<&str>,
        device: &str,
        cameras: Vec<PyRef<'_, ViewCamera>>,
        lit: bool,
        shader: Option<PathBuf>,
    ) -> PyResult<ViewStream> {
        let viewer = self.file("render_views")?.clone();
        let (gpu, options) = render_options(precision, device, lit, shader)?;
        let cameras: Vec<Camera> = cameras.iter().map(|c| c.camera.clone()).collect();
        let remaining = cameras.len();
        // Rendezvous: the thread renders one view ahead, and waits with it.
        let (send, views) = std::sync::mpsc::sync_channel(0);
        std::thread::spawn(move || {
            for camera in cameras {
                let rendered = render_view(&viewer, Some(camera), None, gpu, &options);
                let failed = rendered.is_err();
                if send.send(rendered).is_err() || failed {
                    break;
                }
            }
        });
        Ok(ViewStream {
            state: Mutex::new(Stream { views, remaining }),
        })
    }
}

/// The device and options of a render as Python gives them.
fn render_options(
    precision: Option<&str>,
    device: &str,
    lit: bool,
    shader: Option<PathBuf>,
) -> PyResult<(Option<&'static Gpu>, RenderOptions)> {
    let on_gpu = on_gpu(device)?;
    let precision = (precision.map(str::parse).transpose()).map_err(PyValueError::new_err)?;
    let options = RenderOptions {
        precision,
        shade: shade_hook(lit, shader.as_deref()).map_err(to_py)?,
        ..RenderOptions::default()
    };
    let gpu = match on_gpu {
        true => Some(gpu()?),
        false => None,
    };
    Ok((gpu, options))
}

/// A view's images and their size.
type Rendered = (AnyImages, [u32; 2]);

/// A view's images and size: the scene file's scene seen by `camera` (its own where `None`) at
/// `size` (the camera's where `None`).
fn render_view(
    viewer: &Mutex<Viewer>,
    camera: Option<Camera>,
    size: Option<[u32; 2]>,
    gpu: Option<&Gpu>,
    options: &RenderOptions,
) -> raycast::Result<Rendered> {
    let mut viewer = viewer.lock().expect("the scene's lock");
    let mut camera = camera.unwrap_or_else(|| viewer.as_ref().camera.clone());
    camera.resolution = size.unwrap_or(camera.resolution);
    let size = camera.resolution;
    let images = viewer.render(camera, |scene| match gpu {
        Some(gpu) => gpu.render(scene, options),
        None => Cpu.render(scene, options),
    });
    images.map(|images| (images, size))
}

/// A view's images as a dict of flat arrays with the image size.
fn images_dict(py: Python<'_>, (images, [w, h]): Rendered) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    if let Some(color) = images.color() {
        d.set_item("color", PyArray1::from_vec(py, flat(color.to_vec())))?;
        d.set_item("hook_rays", images.hook_rays())?;
    }
    d.set_item("width", w)?;
    d.set_item("height", h)?;
    match images {
        AnyImages::F32(i) => images_into(py, &d, i)?,
        AnyImages::F64(i) => images_into(py, &d, i)?,
    }
    Ok(d)
}

/// The views of [`Scene::render_each`], as its thread renders them.
#[pyclass(module = "raycast._raycast")]
struct ViewStream {
    /// Taken without the GIL, so that a thread waiting for a view holds no lock Python needs.
    state: Mutex<Stream>,
}

struct Stream {
    views: std::sync::mpsc::Receiver<raycast::Result<Rendered>>,
    /// The views not yet taken; none after an error.
    remaining: usize,
}

#[pymethods]
impl ViewStream {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    /// The next view's dict, or the error its render raised (which ends the views).
    fn __next__<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let next = py.detach(|| {
            let mut stream = self.state.lock().expect("the views");
            if stream.remaining == 0 {
                return None;
            }
            let next = stream.views.recv();
            stream.remaining = match next {
                Ok(Ok(_)) => stream.remaining - 1,
                _ => 0,
            };
            Some(next)
        });
        match next {
            None => Ok(None),
            Some(Ok(rendered)) => images_dict(py, rendered.map_err(to_py)?).map(Some),
            Some(Err(_)) => Err(PyRuntimeError::new_err(
                "render_views: the thread rendering the views stopped",
            )),
        }
    }
}

/// An error of `Scene.views` naming the cameras as Python gave them: `cameras[2].fov: ...`
/// for the library's `<views>: [2].fov: ...` (a position in the JSON made from them is no use).
fn cameras_error(e: raycast::Error) -> PyErr {
    let text = e.to_string();
    let Some(rest) = text.strip_prefix("<views>") else {
        return to_py(e);
    };
    let rest = rest.trim_start_matches(|c: char| c == ':' || c.is_ascii_digit());
    let rest = rest.trim_start();
    let sep = if rest.starts_with('[') { "" } else { ": " };
    PyValueError::new_err(format!("cameras{sep}{rest}"))
}

/// A camera for `Scene.render`, from `Scene.views`.
#[pyclass(frozen, name = "Camera", module = "raycast._raycast")]
struct ViewCamera {
    camera: Camera,
}

#[pymethods]
impl ViewCamera {
    /// The image's size in pixels, `[width, height]`.
    #[getter]
    fn resolution(&self) -> [u32; 2] {
        self.camera.resolution
    }
}

/// Many views of scene files rendered to files, as `raycast render SCENE... --views FILE` (or
/// `--orbit N`) `-o OUT` renders them, for `raycast.distributed`: the driver checks the job and
/// writes the manifest, each worker renders the views it is given with a renderer it keeps, so
/// that the scene it rendered last stays loaded and prepared from one batch to the next.
#[pyclass(module = "raycast._raycast")]
struct ViewJob {
    job: RenderViews,
    renderer: Option<ViewRenderer>,
}

/// `views` as Python gives it: a number of orbit views or a views file.
#[derive(FromPyObject)]
enum ViewsArg {
    Orbit(u32),
    File(PathBuf),
}

#[pymethods]
impl ViewJob {
    /// The command line's job: `formats` as `--format`, `precision` unset as without
    /// `--precision` (the render's default, `Precision::default_for`), the robust algorithms.
    #[new]
    #[pyo3(signature = (scenes, views, out, formats, size=None, precision=None, device="gpu", force=false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        scenes: Vec<PathBuf>,
        views: ViewsArg,
        out: PathBuf,
        formats: Vec<String>,
        size: Option<[u32; 2]>,
        precision: Option<&str>,
        device: &str,
        force: bool,
    ) -> PyResult<Self> {
        let refuse =
            |name: &str, message: String| PyValueError::new_err(format!("{name}: {message}"));
        let device: Device = device.parse().map_err(|m| refuse("device", m))?;
        let precision: Option<Precision> =
            (precision.map(str::parse).transpose()).map_err(|m| refuse("precision", m))?;
        let formats = (formats.iter().map(|f| f.parse()))
            .collect::<Result<Vec<Format>, String>>()
            .map_err(|m| refuse("formats", m))?;
        let render = RenderFiles {
            scene: None,
            size,
            device,
            precision,
            algorithm: Algorithm::Robust,
            spp: None,
            band_rows: None,
            shader: None,
            lit: false,
            kernel: None,
            out_dir: out,
            encoding: Encoding::new(&formats, None).map_err(to_py)?,
            emit_shader: None,
            view: Default::default(),
            split: Default::default(),
        };
        let views = match views {
            ViewsArg::Orbit(n) => Views::Orbit(raycast::Orbit {
                views: n,
                ..raycast::Orbit::default()
            }),
            ViewsArg::File(path) => Views::File(path),
        };
        Ok(ViewJob {
            job: RenderViews {
                scenes,
                views,
                force,
                render,
            },
            renderer: None,
        })
    }

    /// Checks the job (options, scene folder names, every view's name and camera) and that
    /// `OUT` is writable, as `RenderViews::run` does first, and returns how many views it has:
    /// pairs `0..n`, every view of the first scene, then of the next.
    fn check(&self, py: Python<'_>) -> PyResult<usize> {
        py.detach(|| -> raycast::Result<usize> {
            let views = self.job.check()?;
            raycast_files::check_writable(&self.job.render.out_dir)?;
            Ok(views)
        })
        .map_err(to_py)
    }

    /// Renders the views `pairs` in order (each skipped where its folder is complete with the
    /// same record, unless the job forces), each into its folder, one view's files written
    /// while the next renders; how many it rendered.
    fn render(&mut self, py: Python<'_>, pairs: Vec<usize>) -> PyResult<usize> {
        let gpu = match self.job.render.device {
            Device::Gpu => Some(gpu()?),
            Device::Cpu => None,
        };
        let ViewJob { job, renderer } = self;
        py.detach(|| {
            let renderer = match renderer {
                Some(r) => r,
                None => renderer.insert(job.renderer()?),
            };
            renderer.render(gpu, &pairs)
        })
        .map_err(to_py)
    }

    /// Rewrites `OUT/manifest.jsonl` from what the output folder holds; returns its path.
    fn write_manifest(&self, py: Python<'_>) -> PyResult<PathBuf> {
        py.detach(|| self.job.write_manifest()).map_err(to_py)
    }
}

/// The hook `render` asks for: the course's ray tracer (`lit`) or a hook file, not both.
fn shade_hook(lit: bool, shader: Option<&std::path::Path>) -> raycast::Result<Option<ShadeHook>> {
    match (lit, shader) {
        (true, Some(_)) => Err(raycast::Error::Argument {
            option: "lit".into(),
            message:
                "is the shade hook shaders/examples/raytrace.wgsl; give it or shader, not both"
                    .into(),
        }),
        (true, None) => ShadeHook::raytrace().map(Some),
        (false, Some(path)) => ShadeHook::load(path).map(Some),
        (false, None) => Ok(None),
    }
}

fn images_into<T: numpy::Element + bytemuck::Pod>(
    py: Python<'_>,
    d: &Bound<'_, PyDict>,
    i: raycast::Images<T>,
) -> PyResult<()> {
    d.set_item("id", PyArray1::from_vec(py, i.id))?;
    d.set_item("distance", PyArray1::from_vec(py, i.distance))?;
    d.set_item("normal", PyArray1::from_vec(py, flat(i.normal)))?;
    Ok(())
}

/// The GPU adapter raycast runs on: name, backend, driver, device type and features.
#[pyfunction]
fn info(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let gpu = gpu()?;
    let a = gpu.info().adapter;
    let d = PyDict::new(py);
    d.set_item("name", a.name.clone())?;
    d.set_item("backend", format!("{:?}", a.backend))?;
    d.set_item("driver", format!("{} {}", a.driver, a.driver_info))?;
    d.set_item("device_type", format!("{:?}", a.device_type))?;
    let f = gpu.device.features();
    d.set_item("f64", f.contains(wgpu::Features::SHADER_F64))?;
    d.set_item("subgroups", f.contains(wgpu::Features::SUBGROUP))?;
    Ok(d)
}

#[pymodule]
fn _raycast(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Scene>()?;
    m.add_class::<ViewCamera>()?;
    m.add_class::<ViewJob>()?;
    m.add_class::<ViewStream>()?;
    m.add_function(wrap_pyfunction!(info, m)?)?;
    m.add_function(wrap_pyfunction!(invalid_rays, m)?)?;
    m.add_function(wrap_pyfunction!(invalid_points, m)?)?;
    // The package's version, python/Cargo.toml's (maturin gives the wheel the same).
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
