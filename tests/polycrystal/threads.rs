//! Thread-count independence: the grains, springs and relaxed tensor of a polycrystal on
//! one and on two threads, bit for bit.

use super::common::bonded::generated;
use super::{bits, cubic_model, model, relaxed};
use anisobond::prelude::*;

#[test]
fn one_and_two_threads_give_the_same_bits() {
    let p = generated(1200, 51);
    let text = cubic_model(
        "",
        "[grains]\nmean_size = 3\nseed = 4\nboundary_factor = 0.8\n",
    );
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let a = Assembly::new(p.clone(), model(&text)).unwrap();
            let springs: Vec<u64> = [&a.springs.kn, &a.springs.ks, &a.springs.kr, &a.springs.ktw]
                .iter()
                .flat_map(|c| c.iter().map(|x| x.to_bits()))
                .collect();
            (a.grains().unwrap().clone(), springs, bits(&relaxed(&a)))
        })
    };
    let (one, two) = (run(1), run(2));
    assert!(one.0.len() > 10);
    assert_eq!(one, two);
}
