"""Exchange files computed from results: `export` recomputes one run of a `liaison run` result folder and writes it
as CCSDS messages (OEM per spacecraft, TDM of its measurements) through liaison_cli.exchange's writers."""
