//! Shared helpers for the integration tests (mesh directory, validation-on contexts, image compare).
