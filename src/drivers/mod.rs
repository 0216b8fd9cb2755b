//! Thin adapters from embedded-hal / embedded-io to the pure code.
