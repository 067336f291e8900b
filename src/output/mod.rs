//! Outputs: PRINT tables, PLOT files, the state JSON, SAVE/RESTART files (stub).
