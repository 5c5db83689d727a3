//! Cameras. STUB.
