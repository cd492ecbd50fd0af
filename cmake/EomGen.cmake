# add_eom_model() (issue 3).
