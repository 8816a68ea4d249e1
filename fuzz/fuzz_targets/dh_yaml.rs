//! DH YAML loader: any bytes.
mod common;

fn main() {
    afl::fuzz!(|data: &[u8]| {
        if let Ok(text) = std::str::from_utf8(data) {
            if let Ok(chain) = kinechain::Chain::from_dh_yaml_str(text) {
                common::evaluate(&chain, &common::zero(&chain));
                common::evaluate(&chain, &common::turned(&chain));
                common::convert(&chain);
            }
        }
    });
}
