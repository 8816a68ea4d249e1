//! `Chain._write_tf`: a joint log's TF as a ROS 2 bag, the work in [`kinechain::io::tf`];
//! `kinechain.logs.write_tf` reads the sources and calls it.

use crate::arrays::float_array;
use crate::chain::Chain;
use crate::errors::{LogError, StateError};
use kinechain::error::error_chain;
use kinechain::io::tf::{TfError, TfOptions, write_tf};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

#[pymethods]
impl Chain {
    /// Writes `/tf`, `/tf_static` and `/robot_description` for rows `q` (`(n, nq)`, row-major)
    /// stamped `time` (ns) to `path`, never over one of `inputs`. Returns the `/tf` message count
    /// and the moving and fixed joints' counts.
    #[pyo3(signature = (time, q, path, inputs, frame_prefix, world_frame))]
    #[allow(clippy::too_many_arguments)]
    fn _write_tf(
        &self,
        py: Python<'_>,
        time: numpy::PyReadonlyArray1<'_, i64>,
        q: &Bound<'_, PyAny>,
        path: PathBuf,
        inputs: Vec<PathBuf>,
        frame_prefix: String,
        world_frame: String,
    ) -> PyResult<(usize, usize, usize)> {
        let chain = &self.robot.inner;
        let time = time.as_slice()?.to_vec();
        let q = float_array(q, "q")?;
        let q = q.as_slice()?.to_vec();
        let options = TfOptions {
            frame_prefix,
            world_frame,
            description: self.urdf_text(),
        };
        let summary = py
            .detach(|| {
                let inputs: Vec<&Path> = inputs
                    .iter()
                    .chain(&self.origin)
                    .map(PathBuf::as_path)
                    .collect();
                write_tf(chain, &time, &q, &path, &inputs, &options)
            })
            .map_err(|e| match e {
                TfError::Length { .. } | TfError::Row { .. } | TfError::Time { .. } => {
                    StateError::new_err(error_chain(&e))
                }
                _ => LogError::new_err(error_chain(&e)),
            })?;
        Ok((summary.messages, summary.moving, summary.fixed))
    }
}

#[pymethods]
impl Chain {
    /// The HTML page of `kinechain::io::view` for rows `q` (`(n, nq)`, row-major) stamped
    /// `times` (ns) or 0.1 s apart.
    #[pyo3(signature = (q, times=None))]
    fn _view_html(
        &self,
        q: &Bound<'_, PyAny>,
        times: Option<numpy::PyReadonlyArray1<'_, i64>>,
    ) -> PyResult<String> {
        let q = float_array(q, "q")?;
        let times = match &times {
            Some(t) => Some(t.as_slice()?),
            None => None,
        };
        kinechain::io::view::page(&self.robot.inner, q.as_slice()?, times)
            .map_err(|e| StateError::new_err(e.to_string()))
    }
}
