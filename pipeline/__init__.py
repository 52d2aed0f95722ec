"""microslip: assembly, reduction, contact, harmonic balance, continuation, CLI."""
