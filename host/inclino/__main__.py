from inclino.entry import main

raise SystemExit(main())
