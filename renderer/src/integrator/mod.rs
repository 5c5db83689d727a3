//! Integrator. STUB.
