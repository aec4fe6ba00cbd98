pub fn run(_g: &crate::cli::GlobalArgs, _a: &crate::cli::ExamplesArgs) -> crate::failure::CliResult { Ok(()) }
