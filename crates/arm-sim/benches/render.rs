//! Criterion bench: one 640×480 frame (arm over the pre-rendered background, lighting change,
//! sensor noise) from one camera, and one command.

use std::hint::black_box;

use arm_sim::{ArmSim, SimConfig};
use criterion::{Criterion, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let mut config = SimConfig::default();
    config.cameras.truncate(1);
    let mut sim = ArmSim::new(config).expect("default config");
    sim.command(&[1650.0, 1250.0, 1650.0, 1450.0, 1500.0, 1300.0])
        .expect("valid command");
    c.bench_function("capture 640x480, one camera, default scene", |b| {
        b.iter(|| black_box(sim.capture()))
    });
    let mut k = 0u32;
    c.bench_function("command (servo model, sag, table check)", |b| {
        b.iter(|| {
            k = k.wrapping_add(1);
            let s = 1300.0 + (k % 400) as f64;
            sim.command(black_box(&[s, 1400.0, 1500.0, s, 1500.0, 1500.0]))
                .expect("valid command")
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
