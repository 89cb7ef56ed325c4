//! No code: this crate only asks for dependency features (see its `Cargo.toml`), so that the
//! README's demo command and test command build the dependencies once between them.
