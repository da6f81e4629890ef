// Wrapping a type that implements neither `Scenes` nor `DeclaredProblem` (sizes written out).
struct NotDeclared;

fn main() {
    let _ = simhc_cli::Declared::<NotDeclared, 7, 7, 72, 100, 84>::new(NotDeclared);
}
