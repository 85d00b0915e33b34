"""The hostile campaign's cases by area (hostile_campaign.py is the driver): common holds the outcomes,
the registry and the checks, references and scenes what the cases compare with and run on, and each
cases_<area> module a build(args) that registers its cases."""
