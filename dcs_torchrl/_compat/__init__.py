"""What the package knows about its dependencies' insides: the private APIs it touches, each
guarded by a test (:mod:`.private_api`), and the dependency warnings judged harmless (:mod:`.judged_warnings`)."""
