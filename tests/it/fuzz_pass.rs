//! A short, seeded fuzz pass over the loaders and input parsers: deterministic mutations of the
//! seed corpus (`fuzz/seeds/`) and every input kept from the AFL++ runs (`fuzz/corpus/`), with the
//! checks of the AFL targets (`fuzz/fuzz_targets/common.rs`): no panic, no hang, no NaN pose.
//! The long, coverage-guided runs are described in `fuzz/README.md`.

#[path = "../../fuzz/fuzz_targets/common.rs"]
mod checks;

use kinechain::Chain;
use std::path::{Path, PathBuf};

const TOKENS: &[&str] = &[
    "nan",
    ".nan",
    "inf",
    "-.inf",
    "1e308",
    "-1e308",
    "1e-320",
    "0",
    "-0",
    "[",
    "]",
    "{",
    "}",
    ":",
    ",",
    "&a",
    "*a",
    "!degrees ",
    "!radians ",
    "deg(",
    "pi/2",
    "\"",
    "'",
    "\n  - ",
    "<",
    "/>",
    "</",
    "<joint name=\"j\" type=\"revolute\">",
    "<mimic joint=\"j\"/>",
    "xyz=\"1 2\"",
    "axis xyz=\"0 0 0\"",
    "type: cylindrical",
    "convention: axis",
    "limits: [1, 0]",
    "\u{0}",
    "\u{feff}",
    "é",
];

/// xorshift64*: deterministic, no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn mutate(rng: &mut Rng, seed: &[u8], other: &[u8]) -> Vec<u8> {
    let mut v = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(v.len() + 1);
        match rng.below(6) {
            0 if !v.is_empty() => {
                let i = rng.below(v.len());
                v[i] ^= 1 << rng.below(8);
            }
            1 => v
                .splice(at..at, TOKENS[rng.below(TOKENS.len())].bytes())
                .for_each(drop),
            2 if at < v.len() => {
                let end = (at + 1 + rng.below(16)).min(v.len());
                v.drain(at..end);
            }
            3 if at < v.len() => {
                let end = (at + 1 + rng.below(64)).min(v.len());
                let chunk = v[at..end].to_vec();
                v.splice(at..at, chunk).for_each(drop);
            }
            4 if !other.is_empty() => {
                let from = rng.below(other.len());
                let end = (from + 1 + rng.below(128)).min(other.len());
                v.splice(at..at, other[from..end].iter().copied())
                    .for_each(drop);
            }
            _ => v.insert(at.min(v.len()), rng.next() as u8),
        }
    }
    v
}

fn files(dir: &Path) -> Vec<Vec<u8>> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut paths: Vec<PathBuf> = entries
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    paths.sort();
    paths.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

fn run(target: &str, per_seed: usize, check: impl Fn(&str)) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let seeds = files(&root.join("seeds").join(target));
    let corpus = files(&root.join("corpus").join(target));
    assert!(!seeds.is_empty(), "no seeds for {target}");
    for input in &corpus {
        if let Ok(text) = std::str::from_utf8(input) {
            check(text);
        }
    }
    let mut rng = Rng(0x5eed_0000 ^ target.len() as u64);
    let start = std::time::Instant::now();
    for (i, seed) in seeds.iter().enumerate() {
        let other = &seeds[(i + 1) % seeds.len()];
        for _ in 0..per_seed {
            let input = mutate(&mut rng, seed, other);
            if let Ok(text) = std::str::from_utf8(&input) {
                check(text);
            }
        }
    }
    // No input may hang: the whole pass is bounded (a generous limit for slow machines).
    assert!(
        start.elapsed().as_secs() < 60,
        "{target}: {:?}",
        start.elapsed()
    );
}

#[test]
fn dh_yaml_loader() {
    run("dh_yaml", 150, |text| {
        if let Ok(chain) = Chain::from_dh_yaml_str(text) {
            checks::evaluate(&chain, &checks::zero(&chain));
            checks::evaluate(&chain, &checks::turned(&chain));
            checks::convert(&chain);
        }
    });
}

#[test]
fn urdf_loader() {
    run("urdf", 150, |text| {
        if let Ok(chain) = Chain::from_urdf_str(text) {
            checks::evaluate(&chain, &checks::zero(&chain));
            checks::evaluate(&chain, &checks::turned(&chain));
            checks::convert(&chain);
        }
    });
}

fn chains() -> [Chain; 2] {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    [
        Chain::from_file(root.join("robots/cylindrical.yaml")).unwrap(),
        Chain::from_file(root.join("robots/panda.urdf")).unwrap(),
    ]
}

#[test]
fn joint_vector_parser() {
    let chains = chains();
    run("joint_vector", 3000, |text| {
        for chain in &chains {
            if let Ok(q) = kinechain::io::input::joint_vector_from_str(chain, text, "q") {
                checks::evaluate(chain, &q);
            }
        }
    });
}

#[test]
fn batch_line_parser() {
    let chains = chains();
    run("batch_line", 3000, |text| {
        for chain in &chains {
            if let Ok(line) = kinechain::io::input::parse_batch_line(chain, text) {
                checks::evaluate(chain, &line.q);
            }
            checks::header_and_row(chain, text);
        }
    });
}
