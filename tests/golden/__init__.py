"""Golden recordings compared by value (issue 34): see README.md here."""
