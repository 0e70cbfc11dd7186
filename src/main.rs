fn main() {
    println!("anisobond");
}
