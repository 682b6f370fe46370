//! `bar_domain`: the remembrane command line with the BAR-domain plugins
//! (`Custom(name: "bar_domain")` terms and `Custom(name:
//! "protein_diffusion")` systems in scenes).

fn main() -> std::process::ExitCode {
    remembrane::cli::main_with(bar_domain::registry())
}
