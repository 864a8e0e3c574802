//! Writes scenes/default.glb (the committed default scene). A test checks the committed file
//! equals this output.
fn main() -> std::io::Result<()> {
    let glb = lightlearn::scene::default_scene::build(1).to_glb();
    std::fs::write("scenes/default.glb", &glb)?;
    println!("wrote scenes/default.glb ({} bytes)", glb.len());
    Ok(())
}
