//! Binding of the search-recurrent fragment tracker's kernels (SPEC §5):
//! `kalmanfield._core.match_template`.

use crate::segment::Pixel;
use crate::template::{match_template as match_kernel, Frame, Method, Template, Window};
use numpy::{
    Element, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// Adds the domain's items to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(match_template, m)?)
}

/// (x, y, score, surface if asked for) of a search.
type Found<'py> = (f64, f64, f64, Option<Bound<'py, PyArray2<f64>>>);

/// Calls `$body` with `$frame` bound to a `Frame` of the array's pixels (uint8, uint16,
/// float32 or float64, 2-D, C-contiguous); a TypeError for any other dtype.
macro_rules! with_frame {
    ($array:expr, |$frame:ident| $body:expr) => {{
        let array = $array;
        let untyped = array
            .cast::<PyUntypedArray>()
            .map_err(|_| PyTypeError::new_err("frame must be a numpy array"))?;
        if untyped.ndim() != 2 {
            return Err(PyValueError::new_err(format!(
                "frame must be 2-D, got {} dimensions",
                untyped.ndim()
            )));
        }
        macro_rules! arm {
            ($t:ty) => {
                if let Ok(a) = array.extract::<PyReadonlyArray2<$t>>() {
                    let (h, w) = (a.shape()[0], a.shape()[1]);
                    let pixels = frame_pixels(&a)?;
                    let $frame = Frame::new(pixels, h, w)?;
                    return $body;
                }
            };
        }
        arm!(u8);
        arm!(u16);
        arm!(f32);
        arm!(f64);
        Err(PyTypeError::new_err(format!(
            "frame dtype must be uint8, uint16, float32 or float64 (native byte order), got {}",
            untyped.dtype()
        )))
    }};
}

/// The pixels of a C-contiguous frame.
pub(super) fn frame_pixels<'a, T: Element>(a: &'a PyReadonlyArray2<'_, T>) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err("frame must be C-contiguous"))
}

/// A template from a 2-D float64 array.
pub(super) fn template_of(template: &PyReadonlyArray2<'_, f64>) -> PyResult<Template> {
    let (h, w) = (template.shape()[0], template.shape()[1]);
    Ok(Template::new(
        template.as_array().iter().copied().collect(),
        h,
        w,
    )?)
}

/// The search of SPEC §5's correlation-extreme link over `window` = (x0, y0, x1, y1),
/// half-open, default the whole frame: (x, y, score, surface or None), (x, y) the
/// template's top-left.
#[pyfunction]
#[pyo3(signature = (frame, template, window, method, subpixel, return_surface))]
fn match_template<'py>(
    py: Python<'py>,
    frame: &Bound<'py, PyAny>,
    template: PyReadonlyArray2<'py, f64>,
    window: Option<(usize, usize, usize, usize)>,
    method: &str,
    subpixel: bool,
    return_surface: bool,
) -> PyResult<Found<'py>> {
    let template = template_of(&template)?;
    let method = Method::parse(method)?;
    let window = window.map(|(x0, y0, x1, y1)| Window { x0, y0, x1, y1 });
    let options = (method, subpixel, return_surface);
    with_frame!(frame, |f| search(py, &f, &template, window, options))
}

fn search<'py, T: Pixel>(
    py: Python<'py>,
    frame: &Frame<'_, T>,
    template: &Template,
    window: Option<Window>,
    (method, subpixel, return_surface): (Method, bool, bool),
) -> PyResult<Found<'py>> {
    let (m, s) = py.detach(|| match_kernel(frame, template, window, method, subpixel))?;
    let surface = return_surface
        .then(|| PyArray1::from_slice(py, &s.values).reshape([s.rows, s.cols]))
        .transpose()?;
    Ok((m.x, m.y, m.score, surface))
}
