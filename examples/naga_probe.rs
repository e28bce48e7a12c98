fn main() {
    let src = std::fs::read_to_string(std::env::args().nth(1).unwrap()).unwrap();
    match raycast::gpu::shader::validate(&src, "probe") {
        Ok(_) => println!("ok"),
        Err(e) => println!("{e}"),
    }
}
