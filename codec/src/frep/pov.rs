//! POV-Ray export of F-rep models (filled in below).
