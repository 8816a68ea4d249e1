//! One configuration at a time: the evaluation functions ([`kinematics`]), the workspace they
//! fill ([`data`]) and the views of it they return ([`results`]).

pub(crate) mod data;
pub(crate) mod kinematics;
pub(crate) mod results;
