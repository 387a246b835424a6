from liaison_cli.cli import app

app(prog_name="liaison")
