//! Each command reads its scene once and validates its options once,
//! through the job API and through the command line (here, since the job
//! layer names no frontend), for mesh and grid
//! scenes (counted on this thread by `Scene::load` and `validate::check`).

use crate::data::builtin::BuiltIn;
use crate::job::{validate, ClusterJob, ClusterResult, RenderJob};

/// `f`'s value, and the scene reads and validations it did.
fn counted<T>(f: impl FnOnce() -> T) -> (T, [usize; 2]) {
    let before = [
        crate::scene::loads_on_this_thread(),
        validate::checks_on_this_thread(),
    ];
    let t = f();
    let after = [
        crate::scene::loads_on_this_thread(),
        validate::checks_on_this_thread(),
    ];
    (t, [after[0] - before[0], after[1] - before[1]])
}

#[test]
fn each_command_reads_its_scene_once_and_validates_once() {
    let data = BuiltIn::write().unwrap();
    let mesh = data.scenes[1].clone();
    let grid = data.write_grid(12).unwrap();
    for (scene, is_grid) in [(mesh, false), (grid, true)] {
        let mut render = RenderJob::new(&scene);
        (render.width, render.height) = (Some(24), Some(16));
        render.output = data.dir().join("render.png");
        let (out, n) = counted(|| render.run().unwrap());
        assert_eq!(
            n,
            [1, 1],
            "render job, grid {is_grid}: [scene reads, validations]"
        );
        assert_eq!(out.image.width, 24);
        let (r, n) = counted(|| crate::cli::render::run(render.clone()));
        r.unwrap();
        assert_eq!(n, [1, 1], "pvrsim render, grid {is_grid}");

        let mut cluster = ClusterJob::new(&scene);
        cluster.nodes = 2;
        cluster.no_baselines = true;
        (cluster.width, cluster.height) = (Some(24), Some(16));
        cluster.output = data.dir().join("cluster.png");
        let (out, n) = counted(|| cluster.run().unwrap());
        assert_eq!(n, [1, 1], "cluster job, grid {is_grid}");
        assert_eq!(matches!(out, ClusterResult::Grid(_)), is_grid);
        let (r, n) = counted(|| crate::cli::cluster::run(cluster.clone()));
        r.unwrap();
        assert_eq!(n, [1, 1], "pvrsim cluster, grid {is_grid}");
    }
}
