"""PNG figures (matplotlib, Agg backend) of tables and runs."""
