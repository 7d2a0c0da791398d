// A block passed to a control structure is written by name, not called.
package CalledArg

var D1 Quadcopter

func INIT() {
	RepeatWhile(D1.Battery() > 30, SEQ_Body(), PAR_Exit)
}

func SEQ_Body() {
	D1.FlyByX(1)
}

func PAR_Exit() {
	D1.Land()
}
