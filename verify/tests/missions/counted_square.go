// Three rounds of a square, then land: counted loops end by themselves.
package Counted

var D1 Quadcopter
var D2 Quadcopter

func SEQ_Main() {
	PAR_Up()
	RepeatFor(3, SEQ_Square)
	PAR_Down()
}

func PAR_Up() {
	SEQ_Up1()
	SEQ_Up2()
}

func SEQ_Up1() {
	D1.Arm()
	D1.Takeoff(1)
}

func SEQ_Up2() {
	D2.Arm()
	D2.Takeoff(1)
}

func SEQ_Square() {
	D1.FlyByX(1)
	D1.FlyByY(1)
	D1.FlyByX(-1)
	D1.FlyByY(-1)
}

func PAR_Down() {
	D1.Land()
	D2.Land()
}
