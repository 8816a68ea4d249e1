//! Joint vectors as the CLI reads them (`--q`): JSON array, name-keyed object, or a list, for a
//! chain with a cylindrical joint and one with a mimic joint.
mod common;

fn main() {
    let chains = common::input_chains();
    afl::fuzz!(|data: &[u8]| {
        if let Ok(text) = std::str::from_utf8(data) {
            for chain in &chains {
                if let Ok(q) = kinechain::io::input::joint_vector_from_str(chain, text, "q") {
                    common::evaluate(chain, &q);
                }
            }
        }
    });
}
