//! logodds
