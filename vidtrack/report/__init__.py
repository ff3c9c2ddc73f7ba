"""Reports: the run page (report.md/report.html) and the ANOVA page, and their HTML helper."""
