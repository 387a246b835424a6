"""CCSDS Navigation Data Messages in and out: OEM, OPM and TDM (CCSDS 502.0-B-3, 503.0-B-2) read and written in
KVN and XML through the ccsds-ndm library (the optional extra `liaison[ccsds]`), with their time tags, frames
and the OEM's interpolation. Knows nothing of scenarios: scenario setup and the export read and write through
it."""
