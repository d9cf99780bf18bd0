"""The study file -> checked cases: loading and each section's checks, the cases' consistency and
ids, designs, searches and analyses' rules, the names of the plot kinds. Imports only
pipeline.common."""
