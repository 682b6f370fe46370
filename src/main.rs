//! The `remembrane` command line: the library's CLI with the built-in
//! physics only (a user's binary passes its own plugins to `main_with`).

fn main() -> std::process::ExitCode {
    remembrane::cli::main_with(remembrane::scene::registry::PluginRegistry::new())
}
