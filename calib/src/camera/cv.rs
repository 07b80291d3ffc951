//! The little glue between frames and OpenCV matrices.

use opencv::core::Mat;
use opencv::prelude::*;

use super::CameraCalibError;

/// Maps an OpenCV error to ours, naming what was being done.
pub(crate) fn cv_err(what: &str) -> impl FnOnce(opencv::Error) -> CameraCalibError + '_ {
    move |e| CameraCalibError::OpenCv {
        what: what.to_string(),
        message: e.message,
    }
}

/// An owned single-channel 8-bit matrix.
pub(crate) fn mat_gray8(rows: usize, cols: usize, px: &[u8]) -> Result<Mat, CameraCalibError> {
    let what = "building a mask image";
    let m = Mat::new_rows_cols_with_data(rows as i32, cols as i32, px).map_err(cv_err(what))?;
    m.try_clone().map_err(cv_err(what))
}
