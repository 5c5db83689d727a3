//! Render. STUB.
