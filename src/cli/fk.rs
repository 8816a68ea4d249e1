//! `kinechain fk`: one configuration's poses, rates, points and Jacobians.

use crate::cli::args::{FkArgs, OutputFormat};
use crate::cli::bag::fk_bag;
use crate::cli::batch::fk_batch_file;
use crate::cli::common::{load, write_line};
use crate::cli::error::CliError;
use crate::cli::format::{Configuration, csv_header};
use crate::cli::query::Request;
use crate::eval::{Data, LimitPolicy};
use crate::io::input::joint_vector_from_str;
use std::io::Write;

pub(super) fn fk(
    args: &FkArgs,
    options: &crate::io::LoadOptions,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let chain = load(&args.robot, options)?;
    let mut data = Data::new(&chain);
    if args.ignore_limits {
        data.set_limit_policy(LimitPolicy::Ignore);
    }
    let mut request = Request::new(&chain, args)?;
    if args.format == OutputFormat::Csv {
        write_line(out, &csv_header(&chain, args))?;
    }
    if let (Some(path), Some(tf)) = (&args.bag, &args.tf) {
        return crate::cli::bag::tf_bag(&chain, args, path, tf);
    }
    if let Some(path) = &args.bag {
        return fk_bag(&chain, args, &mut data, &mut request, path, out);
    }
    if let Some(path) = &args.batch {
        return fk_batch_file(&chain, args, &mut data, &mut request, path, out);
    }
    let q = args.q.as_deref().unwrap_or_default();
    let c = Configuration {
        q: joint_vector_from_str(&chain, q, "q")?,
        qd: args
            .qd
            .as_deref()
            .map(|t| joint_vector_from_str(&chain, t, "qd"))
            .transpose()?,
        qdd: args
            .qdd
            .as_deref()
            .map(|t| joint_vector_from_str(&chain, t, "qdd"))
            .transpose()?,
    };
    request.emit(&chain, args, &mut data, &c, None, out)
}
