"""What a study writes and reads back: batch files, the ledger, the combine into study.nc, what a
batch stores of its cases (reduce), crack onset, a case's Dataset, sealed files, the study lock.
Imports only pipeline.common and pipeline.study."""
