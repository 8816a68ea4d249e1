//! One line of a `--batch` file, for the same chains as `joint_vector`.
mod common;

fn main() {
    let chains = common::input_chains();
    afl::fuzz!(|data: &[u8]| {
        if let Ok(text) = std::str::from_utf8(data) {
            for chain in &chains {
                if let Ok(line) = kinechain::io::input::parse_batch_line(chain, text) {
                    common::evaluate(chain, &line.q);
                }
                common::header_and_row(chain, text);
            }
        }
    });
}
