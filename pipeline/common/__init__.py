"""What every stage shares: errors and exit statuses, the Ctrl-C flag, the tables of variables and
statuses, and the provenance attributes every result file carries."""
