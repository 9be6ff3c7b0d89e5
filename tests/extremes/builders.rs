//! Device against CPU builders: the same image from either tree.

use super::*;

#[test]
fn device_and_cpu_trees_give_the_same_image() {
    let d = common::device();
    let dir = tempfile::tempdir().unwrap();
    let path = write(&base_spec(), dir.path(), "base");
    let mut st = settings(8, 7);
    st.aovs = Aovs::ALL;
    let dev = render(&d, &path, &st, Tree::Device);
    let cpu = render(&d, &path, &st, Tree::CpuSweep);
    // Different trees (else the comparison would prove nothing) ...
    assert_ne!(dev.bvh, cpu.bvh, "the builders made the same tree");
    eprintln!(
        "SAH cost: device {:.3}, sweep {:.3}",
        bvh::sah_cost(&dev.bvh),
        bvh::sah_cost(&cpu.bvh)
    );
    // ... and the same hits: closest-hit ties break by triangle index and
    // shadow rays only ask whether anything blocks, so the tree cannot
    // change a single bit.
    assert!(bits(&dev.image) == bits(&cpu.image), "images differ");
    st.traversal = Traversal::Stackless;
    let cpu_sl = render(&d, &path, &st, Tree::CpuSweep);
    assert!(bits(&dev.image) == bits(&cpu_sl.image), "stackless differs");
    st.traversal = Traversal::Stack;
    let cpu_binary = render(&d, &path, &st, Tree::CpuSweep);
    assert!(
        bits(&dev.image) == bits(&cpu_binary.image),
        "binary stack differs"
    );
}
