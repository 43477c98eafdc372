from inclino.cli import main

raise SystemExit(main())
