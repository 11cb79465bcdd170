// scratch probe (not committed)
use weft::collide::{Collider, Shape};
use weft::world::*;
use glam::Vec3A;
fn main() {
    let n = 17usize;
    let mut pos = vec![[0.0f32;3]; n*n]; let mut uv = vec![[0.0f32;2]; n*n]; let mut tris = vec![[0u32;3]; 2*(n-1)*(n-1)];
    weft::mesh::grid(n,n,1.0,1.0,&mut pos,&mut uv,&mut tris).unwrap();
    for p in &mut pos { *p = [p[0]-0.5, p[1]-0.5, 0.6]; }
    let mats = vec![0u32; tris.len()];
    let m = [Material{ stiffness: [[600.0, 60.0, 0.0], [60.0, 150.0, 0.0], [0.0, 0.0, 50.0]], density: 0.15, bending: 1e-4}];
    let cap = Capacity{vertices:(n*n) as u32, triangles: tris.len() as u32, edges: 3*tris.len() as u32, colliders: 8, pins: 64};
    let mut mem = vec![0u8; cap.world_bytes()];
    let mut w = World::new(&mut mem, cap, &ClothDef{positions:&pos, uvs:&uv, triangles:&tris, materials:&mats}, Materials::Table(&m), Settings::default()).unwrap();
    let shape = Shape::Sphere{center: Vec3A::new(0.0,0.0,0.0), radius: 0.3};
    w.add_collider(Collider::new(shape, 0.3, 0.01)).unwrap();
    for step in 0..240 {
        let e0 = w.energy();
        match w.step() {
            Ok(s) => if s.redone > 0 || s.energy_removed > 0.0 || step % 20 == 0 { println!("{step}: {:?} E {:?}", s, e0.total()); },
            Err(e) => { println!("{step}: {e:?} E {:?}", e0); break; }
        }
    }
}
