//! Output. STUB.
