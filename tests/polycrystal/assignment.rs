//! Grain assignment against a brute-force nearest-centre search with the minimum image
//! written here, and the grain count of a mean size by hand.

use super::common::bonded::generated;
use super::common::reference::nearest_centre;
use super::{isotropic_model, model};
use anisobond::grains::{count_for_mean_size, nearest_centres};
use anisobond::prelude::*;

/// The brute-force nearest centre of `x` (`common::reference::nearest_centre`: the minimum
/// image by whole cells in the cell of edges `l`, the lower index on a tie), as a grain.
fn brute_force(x: &Vec3, centres: &[Vec3], l: Option<Vec3>) -> u32 {
    nearest_centre(x, centres, l) as u32
}

/// The seeded Voronoi map of a generated periodic packing is the brute-force nearest
/// centre of every particle, minimum image included; a free copy of the packing (no cell)
/// is the plain nearest centre, and differs where the periodic images matter.
#[test]
fn assignment_is_the_brute_force_nearest_centre_with_minimum_image() {
    let p = generated(1500, 21);
    let a = Assembly::new(
        p.clone(),
        model(&isotropic_model("[grains]\ncount = 37\nseed = 5\n")),
    )
    .unwrap();
    let grains = a.grains().unwrap();
    let centres = grains.centres.as_ref().expect("seeded centres");
    assert_eq!(centres.len(), 37);
    let l = p.cell.as_ref().unwrap().lengths;
    for c in centres {
        assert!(
            (0..3).all(|k| 0.0 <= c[k] && c[k] < l[k]),
            "{c:?} outside the cell"
        );
    }
    for (k, x) in p.positions.iter().enumerate() {
        assert_eq!(
            grains.grain[k],
            brute_force(x, centres, Some(l)),
            "particle {k}"
        );
    }
    // Centres hugging the faces: the periodic images decide many particles.
    let near_faces: Vec<Vec3> = (0..8)
        .map(|c| {
            let corner = Vec3::new((c & 1) as f64, ((c >> 1) & 1) as f64, ((c >> 2) & 1) as f64);
            Vec3::new(0.02, 0.03, 0.01) + corner.component_mul(&(l * 0.9))
        })
        .collect();
    let periodic = nearest_centres(&p, &near_faces).unwrap();
    let mut free = p.clone();
    free.cell = None;
    let plain = nearest_centres(&free, &near_faces).unwrap();
    let mut differ = 0;
    for (k, x) in p.positions.iter().enumerate() {
        assert_eq!(
            periodic[k],
            brute_force(x, &near_faces, Some(l)),
            "particle {k}"
        );
        assert_eq!(plain[k], brute_force(x, &near_faces, None), "particle {k}");
        differ += usize::from(periodic[k] != plain[k]);
    }
    assert!(
        differ > 100,
        "{differ} particles change grain with the minimum image"
    );
    // A tie goes to the lower index: two equal centres.
    let twins = vec![near_faces[3], near_faces[3]];
    assert!(nearest_centres(&p, &twins).unwrap().iter().all(|&g| g == 0));
}

/// count = round(V / (size·2R̄)³), at least 1: by hand for the generated cell.
#[test]
fn mean_size_gives_the_documented_count() {
    let p = generated(1000, 22);
    let v = p.cell.as_ref().unwrap().volume();
    let d = 2.0 * p.mean_radius();
    for size in [2.0, 3.0, 5.5] {
        let expected = (v / (size * d).powi(3)).round().max(1.0) as usize;
        assert_eq!(
            count_for_mean_size(&p, size).unwrap(),
            expected,
            "size {size}"
        );
        let text = isotropic_model(&format!("[grains]\nmean_size = {size}\n"));
        let a = Assembly::new(p.clone(), model(&text)).unwrap();
        assert_eq!(a.grains().unwrap().len(), expected);
    }
    assert_eq!(count_for_mean_size(&p, 1e3).unwrap(), 1);
    assert!(matches!(count_for_mean_size(&p, 0.1), Err(Error::Model(_))));
}

/// A specimen cut from the periodic packing (a free cluster): its grains are drawn in the
/// specimen's box and assigned by plain distance; a cross-anisotropic polycrystal cut (μ
/// from the source packing) of one identity grain is the single crystal's cut bit for bit.
#[test]
fn a_cut_specimen_has_grains_in_its_box() {
    use anisobond::packing::Region;
    let p = generated(1200, 23);
    let side = p.cell.as_ref().unwrap().lengths.x;
    let region = Region::Box {
        lo: Vec3::zeros(),
        hi: Vec3::new(side, side, 0.6 * side),
        axis: 2,
    };
    let cross = |tables: &str| {
        model(&format!(
            "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cross-anisotropic\"\n\
             C11 = 30e9\nC33 = 15e9\nC13 = 6e9\nC12 = 8e9\n{tables}"
        ))
    };
    let (a, cut) = Assembly::cut(&p, &region, cross("[grains]\ncount = 9\nseed = 2\n")).unwrap();
    assert!(cut.packing.cell.is_none());
    let grains = a.grains().unwrap();
    assert_eq!(grains.grain.len(), cut.packing.len());
    let (lo, hi) = cut.packing.bounding_box();
    let centres = grains.centres.as_ref().unwrap();
    for c in centres {
        assert!(
            (0..3).all(|k| lo[k] <= c[k] && c[k] <= hi[k]),
            "{c:?} outside the box"
        );
    }
    for (k, x) in cut.packing.positions.iter().enumerate() {
        assert_eq!(
            grains.grain[k],
            brute_force(x, centres, None),
            "particle {k}"
        );
    }
    // One identity grain: the single crystal's cut, springs bit for bit.
    let dir = super::common::tmp();
    std::fs::write(dir.path().join("e.txt"), "0 0 0\n").unwrap();
    let text = "[grains]\ncount = 1\norientation = \"euler-file\"\neuler_file = \"e.txt\"\n";
    let path = dir.path().join("model.toml");
    std::fs::write(
        &path,
        format!(
            "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cross-anisotropic\"\n\
             C11 = 30e9\nC33 = 15e9\nC13 = 6e9\nC12 = 8e9\n{text}"
        ),
    )
    .unwrap();
    let (one, _) = Assembly::cut(&p, &region, Model::from_path(&path).unwrap()).unwrap();
    let (single, _) = Assembly::cut(&p, &region, cross("")).unwrap();
    assert_eq!(one.springs, single.springs);
}
