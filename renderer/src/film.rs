//! Film. STUB.
