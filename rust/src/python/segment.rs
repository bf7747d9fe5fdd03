//! Binding of the frame segmentation (SPEC §3): `kalmanfield._core.segment` and `segment_stack`.

use super::convert::{contiguous, pixel_dtype_error, untyped_array, with_dtype};
use crate::tracking::{
    segment as segment_kernel, segment_stack as stack_kernel, Pixel, Segment, Segmentation,
    StackSegmentation,
};
use numpy::{
    Element, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Adds `segment` to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(segment, m)?)?;
    m.add_function(wrap_pyfunction!(segment_stack, m)?)
}

/// (columns of the segment table, label image) of a thresholded frame.
type SegmentArrays<'py> = (Bound<'py, PyDict>, Bound<'py, PyArray2<i32>>);

/// Segments a 2-D C-contiguous uint8/uint16/float32/float64 frame (SPEC §3): foreground
/// v > threshold, `connectivity` 4 or 8, segments of area < `min_area` dropped. Returns the
/// table (label, x, y, amplitude, area, extent_x, extent_y, bbox_x0, bbox_y0, bbox_x1,
/// bbox_y1; int64 for label, area and bbox, float64 otherwise) and the int32 label image.
#[pyfunction]
fn segment<'py>(
    py: Python<'py>,
    frame: &Bound<'py, PyAny>,
    threshold: f64,
    min_area: usize,
    connectivity: u8,
) -> PyResult<SegmentArrays<'py>> {
    let array = untyped_array(frame, "frame", 2)?;
    let shape = [array.shape()[0], array.shape()[1]];
    let into_arrays = |s: Segmentation| -> PyResult<SegmentArrays<'py>> {
        let labels = PyArray1::from_vec(py, s.labels).reshape(shape)?;
        Ok((table(py, &s.segments)?, labels))
    };
    with_dtype!(frame, PyReadonlyArray2<u8, u16, f32, f64>, |a| {
        into_arrays(kernel(py, &a, threshold, min_area, connectivity)?)
    }, else Err(pixel_dtype_error(array, "frame")))
}

/// Runs the kernel on the array's pixels with the GIL released.
fn kernel<T: Pixel + Element>(
    py: Python<'_>,
    frame: &PyReadonlyArray2<'_, T>,
    threshold: f64,
    min_area: usize,
    connectivity: u8,
) -> PyResult<Segmentation> {
    let (h, w) = (frame.shape()[0], frame.shape()[1]);
    let values = contiguous(frame, "frame")?;
    Ok(py.detach(|| segment_kernel(values, h, w, threshold, min_area, connectivity))?)
}

/// (columns of the stack's segment table with a `frame` column, label images).
type StackArrays<'py> = (Bound<'py, PyDict>, Bound<'py, PyArray3<i32>>);

/// Segments every frame of a 3-D C-contiguous stack (frames × height × width), in parallel
/// over the frames with the GIL released; the table has a leading `frame` column (0-based
/// index in the stack), rows in frame then label order.
#[pyfunction]
fn segment_stack<'py>(
    py: Python<'py>,
    stack: &Bound<'py, PyAny>,
    threshold: f64,
    min_area: usize,
    connectivity: u8,
) -> PyResult<StackArrays<'py>> {
    let array = untyped_array(stack, "stack", 3)?;
    let shape = [array.shape()[0], array.shape()[1], array.shape()[2]];
    let into_arrays = |s: StackSegmentation| -> PyResult<StackArrays<'py>> {
        let frame_of: Vec<i64> = s
            .segments
            .iter()
            .enumerate()
            .flat_map(|(f, frame)| std::iter::repeat_n(f as i64, frame.len()))
            .collect();
        let segments: Vec<&Segment> = s.segments.iter().flatten().collect();
        let dict = table(py, &segments)?;
        dict.set_item("frame", PyArray1::from_vec(py, frame_of))?;
        Ok((dict, PyArray1::from_vec(py, s.labels).reshape(shape)?))
    };
    with_dtype!(stack, PyReadonlyArray3<u8, u16, f32, f64>, |a| {
        let values = contiguous(&a, "stack")?;
        let [f, h, w] = shape;
        let frames =
            py.detach(|| stack_kernel(values, f, h, w, threshold, min_area, connectivity))?;
        into_arrays(frames)
    }, else Err(pixel_dtype_error(array, "stack")))
}

/// A column name and how to read it off a segment.
type Column<T> = (&'static str, fn(&Segment) -> T);

/// The segment table as a dict of 1-D arrays.
fn table<'py, S: std::borrow::Borrow<Segment>>(
    py: Python<'py>,
    segments: &[S],
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    let ints: [Column<usize>; 6] = [
        ("label", |s| s.label),
        ("area", |s| s.area),
        ("bbox_x0", |s| s.bbox_x0),
        ("bbox_y0", |s| s.bbox_y0),
        ("bbox_x1", |s| s.bbox_x1),
        ("bbox_y1", |s| s.bbox_y1),
    ];
    let floats: [Column<f64>; 5] = [
        ("x", |s| s.x),
        ("y", |s| s.y),
        ("amplitude", |s| s.amplitude),
        ("extent_x", |s| s.extent_x),
        ("extent_y", |s| s.extent_y),
    ];
    for (name, get) in ints {
        let column: Vec<i64> = segments.iter().map(|s| get(s.borrow()) as i64).collect();
        dict.set_item(name, PyArray1::from_vec(py, column))?;
    }
    for (name, get) in floats {
        let column: Vec<f64> = segments.iter().map(|s| get(s.borrow())).collect();
        dict.set_item(name, PyArray1::from_vec(py, column))?;
    }
    Ok(dict)
}
