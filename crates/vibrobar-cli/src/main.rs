fn main() {
    println!("vibrobar");
}
