//! Scene. STUB.
