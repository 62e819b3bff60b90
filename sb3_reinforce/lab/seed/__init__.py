"""The re-run of the seed's agent (the blog post's TF1 policy gradient): its environments, hyperparameters, runs."""
